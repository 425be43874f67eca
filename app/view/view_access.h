// Who may use mcpt view's page and API, as Jupyter and TensorBoard users expect: a random
// token per run, printed in the address at start (http://127.0.0.1:8017/?token=...) and then
// held in a cookie (HttpOnly, SameSite=Strict), required on every request; a Host header that
// names the address served (DNS rebinding: a foreign name is refused even with the token);
// requests from other pages refused by their Origin and Sec-Fetch-Site; a POST needs a
// matching Origin or the token in the X-MCPT-Token header (CSRF).
#pragma once
#include <string>

namespace httplib {
struct Request;
}

namespace mcpt {

class ViewAccess {
  public:
    // A new token (128 bits from the system's random source). `listen` is the address served:
    // a loopback address, another address of this machine, or a wildcard (0.0.0.0, ::).
    explicit ViewAccess(std::string listen);
    void set_port(int port) { port_ = port; }
    const std::string& token() const { return token_; }
    // The address to open: http://HOST:PORT/?token=... (127.0.0.1 for a wildcard).
    std::string url() const;

    // Why `req` is refused; empty when it may go on.
    std::string refusal(const httplib::Request& req) const;
    // The request carries the token in its query (the first page load): the page answers by
    // setting the cookie and sending the browser to "/" (the token leaves the address bar).
    bool token_in_query(const httplib::Request& req) const;
    std::string set_cookie() const;

    // 127.0.0.0/8, ::1 and "localhost".
    static bool is_loopback(const std::string& host);
    static bool is_wildcard(const std::string& host);

  private:
    bool host_allowed(const std::string& host_header) const;
    bool has_token(const httplib::Request& req, bool header_only) const;
    std::string listen_, token_;
    int port_ = 0;
};

}  // namespace mcpt
