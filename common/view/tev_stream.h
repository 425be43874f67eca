// Streams a progressive render to tev (the HDR image viewer) over tev's TCP protocol, as
// pbrt-v4's --display-server does: a background thread connects, creates the image once per
// connection and sends the tiles that changed, so that the render never waits on the network.
#pragma once
#include <sys/socket.h>

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <functional>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

namespace mcpt {

class TevStream {
  public:
    // `host_port` is "HOST:PORT" ("[::1]:14158" for an IPv6 literal); throws mcpt::Error on a
    // malformed address, a port outside 1-65535 or a host that does not resolve. `warn` is
    // called (from the stream's thread) the first time tev cannot be reached.
    TevStream(const std::string& host_port, const std::string& image_name,
              std::function<void(const std::string&)> warn = {});
    ~TevStream();  // stops without waiting for tev
    TevStream(const TevStream&) = delete;
    TevStream& operator=(const TevStream&) = delete;

    // Stores a copy of the latest image (3 floats per pixel, top row first) and wakes the
    // thread; never blocks on the network.
    void post(int width, int height, const std::vector<float>& rgb);
    // Sends the last posted image completely, waiting up to `timeout_s` for a connection, then
    // stops the thread. False if tev could not be reached or the send failed in that time.
    bool finish(double timeout_s = 5);

    const std::string& address() const { return address_; }
    // What the thread did so far (tests): connect attempts, connections, tiles sent.
    struct Stats {
        uint64_t attempts = 0, connections = 0, tiles = 0;
    };
    Stats stats() const;

    static constexpr int kTileSize = 128;

  private:
    using Clock = std::chrono::steady_clock;
    void run();
    bool try_connect();
    void disconnect();
    bool peer_closed() const;
    bool send_all(const std::vector<unsigned char>& msg, Clock::time_point deadline);
    bool send_changed_tiles(Clock::time_point deadline);

    std::string address_, name_;
    std::function<void(const std::string&)> warn_;
    std::vector<sockaddr_storage> addrs_;  // what the host resolved to
    std::vector<socklen_t> addr_lens_;

    // Shared with post() and finish(), under mutex_.
    mutable std::mutex mutex_;
    std::condition_variable wake_;
    int width_ = 0, height_ = 0;
    std::vector<float> posted_;
    uint64_t posted_gen_ = 0;
    bool finishing_ = false;
    Clock::time_point finish_deadline_;
    bool finish_ok_ = false;
    Stats stats_;
    std::atomic<bool> stop_{false};

    // The thread's own: the socket, what tev holds on this connection.
    int fd_ = -1;
    int image_w_ = 0, image_h_ = 0;  // the image as posted, copied from posted_
    std::vector<float> image_;
    int created_w_ = 0, created_h_ = 0;  // what CreateImage made on this connection (0: none)
    std::vector<float> sent_;            // the floats tev holds (valid where sent_valid_)
    bool sent_valid_ = false;
    uint64_t sent_gen_ = 0;
    bool warned_ = false;
    Clock::time_point last_attempt_{}, last_send_{};

    std::thread thread_;
};

}  // namespace mcpt
