// cpp-httplib's Server with the bounds Debian's 0.11.4 lacks, enforced on the socket before
// the library parses a request: it predates the fixes for unlimited header counts
// (CVE-2025-52887) and chunked bodies past the payload limit (CVE-2025-46728), reads each
// byte with a fresh timeout (a client sending a byte every few seconds holds a thread
// forever), queues connections without bound, and sets SO_REUSEPORT (a second server on the
// same port binds, and connections split between the two).
//
// Here: a fixed pool of threads and a bounded queue (connections beyond it get 503 at once);
// a request head of at most 16 KiB and 64 lines, read whole within 10 s whatever the pace;
// no chunked request bodies, none over 4 KiB; keep-alive for at most 100 requests and 5 s
// idle; a response write of at most 30 s; the listening socket with SO_REUSEADDR alone.
#pragma once
#include <httplib.h>

#include <atomic>
#include <chrono>
#include <cstddef>

namespace mcpt {

struct GuardLimits {
    size_t threads = 8;         // connections served at once
    size_t queued = 16;         // accepted and waiting for a thread; beyond: 503
    size_t head_bytes = 16384;  // request line and headers
    size_t head_lines = 64;
    size_t body_bytes = 4096;  // Content-Length; chunked bodies are refused
    int requests_per_connection = 100;
    std::chrono::milliseconds head_timeout{10000};   // a whole request head
    std::chrono::milliseconds idle_timeout{5000};    // keep-alive: the next request's first byte
    std::chrono::milliseconds write_timeout{30000};  // a whole response
};

class GuardedServer : public httplib::Server {
  public:
    explicit GuardedServer(GuardLimits limits = {});
    // Ends every wait of the connections being served (a stop does not wait out timeouts).
    void close_connections() { closing_.store(true); }
    const GuardLimits& limits() const { return limits_; }

  private:
    bool process_and_close_socket(socket_t sock) override;
    GuardLimits limits_;
    std::atomic<bool> closing_{false};
};

}  // namespace mcpt
