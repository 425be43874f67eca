#include "app/view/view_server.h"

#include <httplib.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <functional>
#include <nlohmann/json.hpp>

#include "app/view/guarded_server.h"
#include "common/error.h"
#include "common/io/image_io.h"
#include "view_page.h"  // kViewPageHtml, generated from app/view/view_page.html

namespace mcpt {

namespace {

using Json = nlohmann::json;

// The error curve, thinned to at most this many points per request.
constexpr size_t kMaxCurvePoints = 400;

// JSON text; strings that are not valid UTF-8 (a scene file's name) with U+FFFD where the
// bytes are invalid, never an exception.
std::string dump(const Json& j) {
    return j.dump(-1, ' ', false, Json::error_handler_t::replace);
}

// A JSON number, or null for infinity and NaN (JSON has neither).
Json number(double v) {
    return std::isfinite(v) ? Json(v) : Json(nullptr);
}

// Header and data in one body (the format view_server.h describes).
std::string binary_body(const Json& header, const void* data, size_t bytes) {
    std::string head = dump(header);
    head.append((4 - head.size() % 4) % 4, ' ');
    const uint32_t length = uint32_t(head.size());
    std::string body(4 + head.size() + bytes, '\0');
    std::memcpy(&body[0], &length, 4);  // little-endian hosts only (x86-64, arm64)
    std::memcpy(&body[4], head.data(), head.size());
    if (bytes) std::memcpy(&body[4 + head.size()], data, bytes);
    return body;
}

// A pixel's radiance as RGBE (Ward's shared exponent: 8-bit mantissas scaled by 2^(E - 136));
// E = 255 marks a non-finite pixel.
void rgbe(const float (&c)[3], uint8_t* out) {
    const float m = std::max({c[0], c[1], c[2]});
    if (!std::isfinite(c[0] + c[1] + c[2])) {
        out[0] = out[1] = out[2] = 0, out[3] = 255;
        return;
    }
    if (!(m > 1e-32f)) {
        out[0] = out[1] = out[2] = out[3] = 0;
        return;
    }
    // m = f 2^e, f in [0.5, 1): the exponent from the float's bits; scale = 2^(8 - e).
    uint32_t bits;
    std::memcpy(&bits, &m, 4);
    const int e = int((bits >> 23) & 255) - 126;
    const uint32_t scale_bits = uint32_t(127 + 8 - e) << 23;
    float scale;
    std::memcpy(&scale, &scale_bits, 4);
    for (int k = 0; k < 3; ++k) out[k] = uint8_t(std::min(std::max(c[k] * scale, 0.f), 255.f));
    out[3] = uint8_t(e + 128);
}

// The error byte: 1 + round(254 t), t = (log10 e + 3) / 3 clamped to [0, 1] (0.1% to 100%),
// with log2 from the float's bits and a quadratic in the mantissa (within 0.005: under half a
// step of the byte).
uint8_t error_byte(float e) {
    if (!(e <= 1.f)) return 255;  // 100% and more, or NaN
    if (!(e > 1e-3f)) return 1;
    uint32_t bits;
    std::memcpy(&bits, &e, 4);
    const float x = float(bits & 0x7fffff) / float(1 << 23);  // mantissa - 1, in [0, 1)
    const float log2e = float(int(bits >> 23) - 127) + x * (1.3466f - 0.3466f * x);
    const float t = (log2e * 0.30103f + 3.f) / 3.f;
    return uint8_t(1 + std::lround(254 * std::min(std::max(t, 0.f), 1.f)));
}

// A frame: RGBE per pixel, then one byte per pixel for the relative error (standard error of
// the channel mean / the mean; 0 unknown, else 1 + 254 t for t = (log10 e + 3) / 3 clamped:
// 0.1% to 100%). About 5 bytes a pixel; exact values come from /api/pixel.
std::string frame_body(const LiveSnapshot& snap) {
    const RenderResult& r = snap.result;
    const size_t n = size_t(r.width) * size_t(r.height);
    std::vector<uint8_t> v(5 * n);
    for (size_t i = 0; i < n; ++i) {
        float mean[3], err = 0;
        for (int k = 0; k < 3; ++k) {
            const ChannelStats st = channel_stats(r, i, k);
            mean[k] = st.mean, err += st.std_error;
        }
        rgbe(mean, &v[4 * i]);
        const float m = mean[0] + mean[1] + mean[2];
        v[4 * n + i] = m > 0 ? error_byte(err / m) : 0;
    }
    const Json h = {{"width", r.width},
                    {"height", r.height},
                    {"spp", r.spp},
                    {"serial", snap.serial},
                    {"samples_per_second", snap.samples_per_second},
                    {"relative_error", number(snap.relative_error)},
                    {"invalid", r.nonfinite_total}};
    return binary_body(h, v.data(), v.size());
}

// The side a request names (?side=0 or 1), or -1.
int side_of(const httplib::Request& req, size_t sides) {
    if (!req.has_param("side")) return 0;
    const std::string s = req.get_param_value("side");
    if (s == "0" || (s == "1" && sides > 1)) return s[0] - '0';
    return -1;
}

uint64_t since_of(const httplib::Request& req) {
    if (!req.has_param("since")) return 0;
    try {
        return std::stoull(req.get_param_value("since"));
    } catch (const std::exception&) {
        return 0;
    }
}

// A handler whose exceptions become a 500 with the message, never a dropped connection.
httplib::Server::Handler guarded(
    std::function<void(const httplib::Request&, httplib::Response&)> f) {
    return [f](const httplib::Request& req, httplib::Response& res) {
        try {
            f(req, res);
        } catch (const std::exception& e) {
            res.status = 500;
            res.set_content(std::string("error: ") + e.what() + "\n", "text/plain");
        }
    };
}

}  // namespace

ViewServer::ViewServer(LiveRender& live, ViewInfo info, const std::string& listen)
    : live_(live),
      info_(std::move(info)),
      listen_(listen),
      access_(listen),
      server_(std::make_unique<GuardedServer>()) {
    httplib::Server& s = *server_;
    // Every request: this viewer's Host, the token, no other page's Origin (view_access.h).
    s.set_pre_routing_handler([this](const httplib::Request& req, httplib::Response& res) {
        const std::string why = access_.refusal(req);
        if (why.empty()) return httplib::Server::HandlerResponse::Unhandled;
        res.status = 403;
        res.set_content("forbidden: " + why + "\n", "text/plain");
        return httplib::Server::HandlerResponse::Handled;
    });
    s.set_default_headers({{"Cache-Control", "no-store"},
                           {"X-Content-Type-Options", "nosniff"},
                           {"X-Frame-Options", "DENY"},
                           {"Content-Security-Policy", "frame-ancestors 'none'"},
                           {"Referrer-Policy", "no-referrer"}});
    // The page; loaded with ?token=, it sets the cookie and sends the browser to "/".
    s.Get("/", guarded([this](const httplib::Request& req, httplib::Response& res) {
              if (access_.token_in_query(req)) {
                  res.set_header("Set-Cookie", access_.set_cookie());
                  res.set_redirect("/", 303);
                  return;
              }
              res.set_content(kViewPageHtml, "text/html; charset=utf-8");
          }));
    s.Get("/api/state", guarded([this](const httplib::Request&, httplib::Response& res) {
              res.set_content(state_json(), "application/json");
          }));
    // A side's next image: a long poll, answered as soon as the image exists (204 after a
    // second without one).
    s.Get("/api/frame", guarded([this](const httplib::Request& req, httplib::Response& res) {
              const int side = side_of(req, live_.sides());
              if (side < 0) {
                  res.status = 404;
                  return;
              }
              const std::shared_ptr<const LiveSnapshot> snap =
                  live_.next_snapshot(size_t(side), since_of(req), 1.0);
              if (!snap || snap->serial == since_of(req)) {
                  res.status = 204;
                  return;
              }
              res.set_content(frame_body(*snap), "application/octet-stream");
              ++frames_;
          }));
    // A/B: the maps at the latest milestone both sides reached.
    s.Get("/api/maps", guarded([this](const httplib::Request& req, httplib::Response& res) {
              const std::shared_ptr<const LiveMaps> m = live_.sides() == 2 ? live_.maps() : nullptr;
              if (!m || m->spp == since_of(req)) {
                  res.status = 204;
                  return;
              }
              const DifferenceMaps& d = m->maps;
              std::vector<float> v(2 * d.z.size());
              float max_z = 0;
              for (size_t i = 0; i < d.z.size(); ++i) {
                  v[2 * i] = d.z[i], v[2 * i + 1] = d.relative[i];
                  if (std::isfinite(d.z[i])) max_z = std::max(max_z, std::abs(d.z[i]));
              }
              const Json h = {{"width", d.width},
                              {"height", d.height},
                              {"channels", 2},
                              {"spp", m->spp},
                              {"diverged", d.same_seed.diverged},
                              {"pixels", d.same_seed.pixels},
                              {"tolerance", d.same_seed.tolerance},
                              {"max_abs_z", max_z}};
              res.set_content(binary_body(h, v.data(), 4 * v.size()), "application/octet-stream");
          }));
    // One pixel's values on every side (hover): radiance, standard error, samples; the maps.
    s.Get("/api/pixel", guarded([this](const httplib::Request& req, httplib::Response& res) {
              long x = -1, y = -1;
              try {
                  x = std::stol(req.get_param_value("x")), y = std::stol(req.get_param_value("y"));
              } catch (const std::exception&) {
              }
              Json j = {{"x", x}, {"y", y}, {"sides", Json::array()}};
              for (size_t s = 0; s < live_.sides(); ++s) {
                  const std::shared_ptr<const LiveSnapshot> snap = live_.latest(s);
                  if (!snap || x < 0 || y < 0 || x >= snap->result.width ||
                      y >= snap->result.height) {
                      j["sides"].push_back(nullptr);
                      continue;
                  }
                  const RenderResult& r = snap->result;
                  const size_t i = size_t(y) * size_t(r.width) + size_t(x);
                  Json side = {{"spp", r.spp},
                               {"samples", r.pixel_samples(i) - r.nonfinite[i]},
                               {"invalid", r.nonfinite[i]}};
                  for (int c = 0; c < 3; ++c) {
                      const ChannelStats st = channel_stats(r, i, c);
                      side["radiance"].push_back(number(st.mean));
                      side["std_error"].push_back(number(st.std_error));
                  }
                  j["sides"].push_back(side);
              }
              const std::shared_ptr<const LiveMaps> m = live_.sides() == 2 ? live_.maps() : nullptr;
              if (m && x >= 0 && y >= 0 && x < m->maps.width && y < m->maps.height) {
                  const size_t i = size_t(y) * size_t(m->maps.width) + size_t(x);
                  j["maps"] = {{"spp", m->spp},
                               {"z", number(m->maps.z[i])},
                               {"relative", number(m->maps.relative[i])}};
              }
              res.set_content(dump(j), "application/json");
          }));
    // The image as a file: linear EXR or sRGB PNG.
    s.Get("/api/save", guarded([this](const httplib::Request& req, httplib::Response& res) {
              const int side = side_of(req, live_.sides());
              const std::string format =
                  req.has_param("format") ? req.get_param_value("format") : "exr";
              if (side < 0 || (format != "exr" && format != "png")) {
                  res.status = 404;
                  return;
              }
              const std::shared_ptr<const LiveSnapshot> snap = live_.snapshot(size_t(side));
              if (!snap) {
                  res.status = 409;
                  res.set_content("no samples yet\n", "text/plain");
                  return;
              }
              const RenderResult& r = snap->result;
              const std::vector<unsigned char> bytes =
                  encode_image(format, r.width, r.height, r.mean_image());
              const std::string name = "mcpt-" +
                                       std::string(live_.sides() == 2 ? (side ? "B-" : "A-") : "") +
                                       std::to_string(r.spp) + "spp." + format;
              res.set_header("Content-Disposition", "attachment; filename=\"" + name + "\"");
              res.set_content(std::string(bytes.begin(), bytes.end()),
                              format == "exr" ? "image/x-exr" : "image/png");
          }));
    // Controls.
    const auto ok = [](httplib::Response& res) { res.set_content("{}", "application/json"); };
    s.Post("/api/pause", guarded([this, ok](const httplib::Request&, httplib::Response& res) {
               live_.set_paused(true), ok(res);
           }));
    s.Post("/api/resume", guarded([this, ok](const httplib::Request&, httplib::Response& res) {
               live_.set_paused(false), ok(res);
           }));
    s.Post("/api/reset", guarded([this, ok](const httplib::Request&, httplib::Response& res) {
               live_.reset(), ok(res);
           }));
}

ViewServer::~ViewServer() {
    stop();
}

int ViewServer::bind(int port) {
    const int bound = port == 0 ? server_->bind_to_any_port(listen_.c_str())
                                : (server_->bind_to_port(listen_.c_str(), port) ? port : -1);
    if (bound <= 0)
        throw Error("cannot listen on " + listen_ + ":" +
                    (port == 0 ? std::string("any port") : std::to_string(port)) +
                    " (in use, or not an address of this machine)" +
                    (port == 0 ? "" : "; --port 0 takes a free one"));
    access_.set_port(bound);
    return bound;
}

void ViewServer::serve() {
    server_->listen_after_bind();
}

void ViewServer::stop() {
    if (!server_) return;
    server_->close_connections();
    server_->stop();
}

uint64_t ViewServer::frames_sent() const {
    return frames_.load();
}

std::string ViewServer::state_json() {
    Json j;
    j["scene"] = info_.scene;
    j["paused"] = live_.paused();
    j["failure"] = live_.failure();
    j["done"] = live_.done();
    Json sides = Json::array();
    for (size_t s = 0; s < live_.sides(); ++s) {
        const std::vector<ErrorPoint> series = live_.error_series(s);
        const std::shared_ptr<const LiveSnapshot> snap = live_.latest(s);
        Json side;
        side["label"] = info_.sides[s];
        const ErrorPoint last = series.empty() ? ErrorPoint{} : series.back();
        side["spp"] = last.spp;
        side["seconds"] = last.seconds;
        side["relative_error"] = number(last.relative_error);
        const LiveRates rates = live_.rates(s);
        side["samples_per_second"] = rates.samples_per_second;
        side["rays_per_second"] = rates.rays_per_second;
        side["invalid"] = snap ? snap->result.nonfinite_total : 0;
        side["serial"] = snap ? snap->serial : 0;
        // Several devices: each one's share of the samples, as `render` prints it.
        Json devices = Json::array();
        {
            const std::vector<WorkerStats> stats = live_.device_stats(s);
            uint64_t all = 0;
            for (const WorkerStats& w : stats) all += w.samples;
            for (const WorkerStats& w : stats)
                devices.push_back({{"name", w.name},
                                   {"chunks", w.chunks},
                                   {"samples", w.samples},
                                   {"share", all > 0 ? double(w.samples) / double(all) : 0.0}});
        }
        side["devices"] = devices;
        // The curve: every point, or evenly thinned (the last one kept).
        Json curve = Json::array();
        const size_t stride = series.size() / kMaxCurvePoints + 1;
        for (size_t i = 0; i < series.size(); ++i)
            if (i % stride == 0 || i + 1 == series.size())
                curve.push_back(
                    {series[i].seconds, series[i].spp, number(series[i].relative_error)});
        side["curve"] = curve;
        sides.push_back(side);
    }
    j["sides"] = sides;
    return dump(j);
}

}  // namespace mcpt
