#include "app/view/view_access.h"

#include <arpa/inet.h>
#include <httplib.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <random>

namespace mcpt {

namespace {

constexpr const char* kCookie = "mcpt_view";

std::string lower(std::string s) {
    std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return std::tolower(c); });
    return s;
}

// Equal, in a time that does not depend on where they first differ.
bool same_secret(const std::string& a, const std::string& b) {
    if (a.size() != b.size()) return false;
    unsigned char diff = 0;
    for (size_t i = 0; i < a.size(); ++i) diff |= static_cast<unsigned char>(a[i] ^ b[i]);
    return diff == 0;
}

bool is_ip_literal(const std::string& name) {
    unsigned char buf[16];
    if (inet_pton(AF_INET, name.c_str(), buf) == 1) return true;
    return name.size() > 2 && name.front() == '[' && name.back() == ']' &&
           inet_pton(AF_INET6, name.substr(1, name.size() - 2).c_str(), buf) == 1;
}

// "host:port", "[v6]:port" or "host" -> name (brackets kept for IPv6) and port (-1: none).
bool split_authority(const std::string& authority, std::string& name, int& port) {
    port = -1;
    size_t colon = std::string::npos;
    if (!authority.empty() && authority[0] == '[') {
        const size_t close = authority.find(']');
        if (close == std::string::npos) return false;
        name = authority.substr(0, close + 1);
        if (close + 1 < authority.size()) {
            if (authority[close + 1] != ':') return false;
            colon = close + 1;
        }
    } else {
        colon = authority.find(':');
        name = authority.substr(0, colon);
    }
    if (colon != std::string::npos) {
        const std::string digits = authority.substr(colon + 1);
        if (digits.empty() || digits.size() > 5 ||
            !std::all_of(digits.begin(), digits.end(),
                         [](unsigned char c) { return std::isdigit(c); }))
            return false;
        port = std::stoi(digits);
    }
    name = lower(name);
    return !name.empty();
}

}  // namespace

ViewAccess::ViewAccess(std::string listen) : listen_(lower(std::move(listen))) {
    std::random_device source;  // getrandom() on Linux
    static const char* hex = "0123456789abcdef";
    for (int i = 0; i < 8; ++i) {
        const uint32_t word = source();
        for (int k = 0; k < 8; k += 2) {
            const unsigned byte = (word >> (4 * k)) & 0xff;
            token_ += hex[byte >> 4], token_ += hex[byte & 15];
        }
    }
    token_.resize(32);
}

bool ViewAccess::is_loopback(const std::string& host) {
    const std::string h = lower(host);
    unsigned char v4[4];
    if (inet_pton(AF_INET, h.c_str(), v4) == 1) return v4[0] == 127;
    return h == "localhost" || h == "::1" || h == "[::1]";
}

bool ViewAccess::is_wildcard(const std::string& host) {
    return host == "0.0.0.0" || host == "::" || host == "[::]" || host.empty();
}

std::string ViewAccess::url() const {
    std::string host = is_wildcard(listen_) ? "127.0.0.1" : listen_;
    if (host.find(':') != std::string::npos && host.front() != '[') host = "[" + host + "]";
    return "http://" + host + ":" + std::to_string(port_) + "/?token=" + token_;
}

bool ViewAccess::host_allowed(const std::string& host_header) const {
    std::string name;
    int port = -1;
    if (!split_authority(host_header, name, port)) return false;
    if ((port < 0 ? 80 : port) != port_) return false;  // no port: HTTP's 80
    if (name == "localhost" || name == "127.0.0.1" || name == "[::1]") return true;
    std::string served = listen_;
    if (served.find(':') != std::string::npos && served.front() != '[') served = "[" + served + "]";
    if (name == served) return true;
    if (!is_wildcard(listen_)) return false;
    // Served on every address: any address literal, or this machine's own name; never another
    // name (a DNS-rebinding page's).
    if (is_ip_literal(name)) return true;
    char self[256] = "";
    return gethostname(self, sizeof self - 1) == 0 && name == lower(self);
}

bool ViewAccess::has_token(const httplib::Request& req, bool header_only) const {
    if (same_secret(req.get_header_value("X-MCPT-Token"), token_)) return true;
    if (header_only) return false;
    if (req.has_param("token") && same_secret(req.get_param_value("token"), token_)) return true;
    // Cookie: name=value pairs separated by "; ".
    const std::string cookies = req.get_header_value("Cookie");
    const std::string key = std::string(kCookie) + "=";
    for (size_t at = 0; at < cookies.size();) {
        const size_t end = std::min(cookies.find(';', at), cookies.size());
        std::string pair = cookies.substr(at, end - at);
        pair.erase(0, pair.find_first_not_of(' '));
        if (pair.rfind(key, 0) == 0 && same_secret(pair.substr(key.size()), token_)) return true;
        at = end + 1;
    }
    return false;
}

std::string ViewAccess::refusal(const httplib::Request& req) const {
    // DNS rebinding: the Host must name the address served.
    if (!req.has_header("Host") || !host_allowed(req.get_header_value("Host")))
        return "the Host header '" + req.get_header_value("Host").substr(0, 80) +
               "' does not name this viewer's address";
    // Another page's request: a foreign Origin, or the browser saying it is cross-site.
    const bool has_origin = req.has_header("Origin");
    if (has_origin && req.get_header_value("Origin") != "http://" + req.get_header_value("Host"))
        return "a request from another origin (" + req.get_header_value("Origin").substr(0, 80) +
               ")";
    const std::string site = req.get_header_value("Sec-Fetch-Site");
    if (site == "cross-site" || site == "same-site")
        return "a request from another site (Sec-Fetch-Site: " + site + ")";
    if (!has_token(req, false))
        return "no valid token: open the address mcpt view printed (it ends in ?token=...)";
    // A POST changes the render: a same-origin page's (Origin) or a client's with the token
    // in a header.
    if (req.method != "GET" && req.method != "HEAD" && !has_origin && !has_token(req, true))
        return "a POST needs the Origin header of this viewer's page or the X-MCPT-Token header";
    return "";
}

bool ViewAccess::token_in_query(const httplib::Request& req) const {
    return req.has_param("token") && same_secret(req.get_param_value("token"), token_);
}

std::string ViewAccess::set_cookie() const {
    return std::string(kCookie) + "=" + token_ + "; Path=/; HttpOnly; SameSite=Strict";
}

}  // namespace mcpt
