#include "common/view/tev_stream.h"

#include <fcntl.h>
#include <netdb.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>

#include "common/error.h"

namespace mcpt {

namespace {

using namespace std::chrono_literals;

constexpr auto kRoundInterval = 250ms;  // between rounds of tiles
constexpr auto kRetryInterval = 1s;     // between connection attempts
constexpr auto kConnectTimeout = 500ms;
constexpr auto kStallTimeout = 2s;  // a send that makes no progress for this long fails
// A message (a tile: 192 KiB) not sent in this long fails, however it trickles: a peer that
// reads a byte at a time must not hold the stream.
constexpr auto kMessageTimeout = 4s;
constexpr uint8_t kCreateImage = 4, kUpdateImage = 6;  // tev's IpcPacket types (v3 update)
const char* const kChannels[3] = {"R", "G", "B"};

// One message: uint32 length (little-endian, these 4 bytes included), uint8 type, payload.
struct Message {
    std::vector<unsigned char> bytes;
    explicit Message(uint8_t type) : bytes(4, 0) { bytes.push_back(type); }
    void u8(uint8_t v) { bytes.push_back(v); }
    void u32(uint32_t v) {
        for (int i = 0; i < 4; ++i) bytes.push_back(uint8_t(v >> (8 * i)));
    }
    void i32(int32_t v) { u32(uint32_t(v)); }
    void i64(int64_t v) {
        for (int i = 0; i < 8; ++i) bytes.push_back(uint8_t(uint64_t(v) >> (8 * i)));
    }
    void f32(float v) {
        uint32_t u;
        std::memcpy(&u, &v, 4);
        u32(u);
    }
    void str(const std::string& s) {
        bytes.insert(bytes.end(), s.begin(), s.end());
        bytes.push_back(0);
    }
    const std::vector<unsigned char>& done() {
        const uint32_t n = uint32_t(bytes.size());
        for (int i = 0; i < 4; ++i) bytes[size_t(i)] = uint8_t(n >> (8 * i));
        return bytes;
    }
};

// "HOST:PORT" (or "[V6]:PORT") split into host and port; throws on anything else.
void parse_address(const std::string& hp, std::string& host, int& port) {
    const std::string bad = "tev address '" + hp + "' is malformed: ";
    const std::string usage = bad + "expected HOST:PORT, e.g. localhost:14158 (tev's port)";
    const size_t colon = hp.rfind(':');
    if (colon == std::string::npos || colon == 0 || colon + 1 == hp.size()) throw Error(usage);
    host = hp.substr(0, colon);
    if (host.size() > 2 && host.front() == '[' && host.back() == ']')
        host = host.substr(1, host.size() - 2);
    else if (host.find_first_of(":[]") != std::string::npos)
        throw Error(bad + "an IPv6 address goes in brackets, e.g. [::1]:14158");
    const std::string digits = hp.substr(colon + 1);
    if (digits.find_first_not_of("0123456789") != std::string::npos) throw Error(usage);
    if (digits.size() > 5 || std::stoi(digits) < 1 || std::stoi(digits) > 65535)
        throw Error("tev address '" + hp + "': port " + digits + " is out of range (1-65535)");
    port = std::stoi(digits);
}

}  // namespace

TevStream::TevStream(const std::string& host_port, const std::string& image_name,
                     std::function<void(const std::string&)> warn)
    : address_(host_port), name_(image_name), warn_(std::move(warn)) {
    // Parse and resolve now, so that a bad address fails before anything renders.
    std::string host;
    int port = 0;
    parse_address(host_port, host, port);
    addrinfo hints{};
    hints.ai_family = AF_UNSPEC;
    hints.ai_socktype = SOCK_STREAM;
    hints.ai_flags = AI_NUMERICSERV;
    addrinfo* found = nullptr;
    const int rc = getaddrinfo(host.c_str(), std::to_string(port).c_str(), &hints, &found);
    if (rc != 0)
        throw Error("tev address '" + host_port + "': cannot resolve host '" + host +
                    "': " + gai_strerror(rc));
    for (const addrinfo* a = found; a; a = a->ai_next) {
        sockaddr_storage s{};
        std::memcpy(&s, a->ai_addr, a->ai_addrlen);
        addrs_.push_back(s);
        addr_lens_.push_back(a->ai_addrlen);
    }
    freeaddrinfo(found);
    if (addrs_.empty()) throw Error("tev address '" + host_port + "': no address for the host");
    thread_ = std::thread([this] { run(); });
}

TevStream::~TevStream() {
    // Stop at once: the thread checks stop_ between short polls.
    {
        std::lock_guard<std::mutex> lock(mutex_);
        stop_ = true;
    }
    wake_.notify_all();
    if (thread_.joinable()) thread_.join();
    disconnect();
}

void TevStream::post(int width, int height, const std::vector<float>& rgb) {
    if (width <= 0 || height <= 0 || rgb.size() != 3 * size_t(width) * size_t(height))
        throw Error("TevStream::post: the image is not width x height RGB floats");
    {
        std::lock_guard<std::mutex> lock(mutex_);
        width_ = width, height_ = height;
        posted_.assign(rgb.begin(), rgb.end());
        ++posted_gen_;
    }
    wake_.notify_all();
}

bool TevStream::finish(double timeout_s) {
    {
        std::lock_guard<std::mutex> lock(mutex_);
        if (!thread_.joinable()) return finish_ok_;
        finishing_ = true;
        finish_deadline_ =
            Clock::now() + std::chrono::duration_cast<Clock::duration>(
                               std::chrono::duration<double>(std::max(timeout_s, 0.0)));
    }
    wake_.notify_all();
    thread_.join();
    disconnect();
    std::lock_guard<std::mutex> lock(mutex_);
    return finish_ok_;
}

TevStream::Stats TevStream::stats() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return stats_;
}

void TevStream::run() {
    std::unique_lock<std::mutex> lock(mutex_);
    uint64_t image_gen = 0;  // the generation in image_
    while (!stop_) {
        const auto now = Clock::now();
        const bool dirty = posted_gen_ != 0 && posted_gen_ != sent_gen_;
        // Drop a connection tev closed (restarted, or the window closed) before sending on it.
        if (fd_ >= 0 && (dirty || finishing_) && peer_closed()) {
            disconnect();
            continue;
        }
        // finish(): done once tev holds the last image, failed at the deadline.
        if (finishing_ && !dirty) {
            finish_ok_ = true;
            break;
        }
        if (finishing_ && now >= finish_deadline_) break;
        // Nothing to send: sleep until post(), finish() or the destructor.
        if (!dirty && !finishing_) {
            wake_.wait(lock);
            continue;
        }
        // Rounds 250 ms apart (finish(): at once), connection attempts a second apart.
        const auto ready = fd_ >= 0 ? (finishing_ ? now : last_send_ + kRoundInterval)
                                    : last_attempt_ + kRetryInterval;
        if (now < ready) {
            wake_.wait_until(lock, finishing_ ? std::min(ready, finish_deadline_) : ready);
            continue;
        }
        // Take the latest image (post() refills posted_ meanwhile).
        if (image_gen != posted_gen_) {
            image_.swap(posted_);
            image_w_ = width_, image_h_ = height_, image_gen = posted_gen_;
        }
        const auto deadline = finishing_ ? finish_deadline_ : Clock::time_point::max();
        lock.unlock();
        // Connect if needed; warn the first time tev cannot be reached.
        bool ok = true;
        if (fd_ < 0) {
            last_attempt_ = now;
            ok = try_connect();
            if (!ok && !warned_) {
                warned_ = true;
                if (warn_) warn_("tev at " + address_ + " not reachable, retrying");
            }
        }
        // Send what changed; a failed send closes the socket (reconnect later).
        if (ok) {
            ok = send_changed_tiles(deadline);
            last_send_ = Clock::now();
            if (!ok) disconnect();
        }
        lock.lock();
        if (ok) sent_gen_ = image_gen;
    }
}

bool TevStream::try_connect() {
    {
        std::lock_guard<std::mutex> lock(mutex_);
        ++stats_.attempts;
    }
    for (size_t i = 0; i < addrs_.size() && !stop_; ++i) {
        // Non-blocking connect, waited for in short polls up to the timeout.
        const int fd = socket(addrs_[i].ss_family, SOCK_STREAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
        if (fd < 0) continue;
        int rc = connect(fd, reinterpret_cast<const sockaddr*>(&addrs_[i]), addr_lens_[i]);
        if (rc != 0 && errno == EINPROGRESS) {
            const auto give_up = Clock::now() + kConnectTimeout;
            pollfd p{fd, POLLOUT, 0};
            while (!stop_ && Clock::now() < give_up && (rc = poll(&p, 1, 50)) == 0) {
            }
            int err = 0;
            socklen_t len = sizeof(err);
            rc = rc > 0 && getsockopt(fd, SOL_SOCKET, SO_ERROR, &err, &len) == 0 && err == 0 ? 0
                                                                                             : -1;
        }
        if (rc != 0) {
            close(fd);
            continue;
        }
        // Connected: no Nagle delay on the small CreateImage.
        const int one = 1;
        setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof(one));
        fd_ = fd;
        std::lock_guard<std::mutex> lock(mutex_);
        ++stats_.connections;
        return true;
    }
    return false;
}

void TevStream::disconnect() {
    if (fd_ >= 0) close(fd_);
    fd_ = -1;
    created_w_ = created_h_ = 0;
    sent_valid_ = false;
    sent_gen_ = 0;
}

bool TevStream::peer_closed() const {
    // tev never writes to us: a readable socket is an end of stream or an error.
    pollfd p{fd_, POLLIN, 0};
    if (poll(&p, 1, 0) <= 0) return false;
    if (p.revents & (POLLERR | POLLHUP)) return true;
    char buf[256];
    const ssize_t n = recv(fd_, buf, sizeof(buf), MSG_DONTWAIT);
    return n == 0 || (n < 0 && errno != EAGAIN && errno != EWOULDBLOCK && errno != EINTR);
}

bool TevStream::send_all(const std::vector<unsigned char>& msg, Clock::time_point deadline) {
    size_t done = 0;
    auto progress = Clock::now();
    deadline = std::min(deadline, progress + kMessageTimeout);
    while (done < msg.size()) {
        if (stop_) return false;
        const ssize_t n = send(fd_, msg.data() + done, msg.size() - done, MSG_NOSIGNAL);
        if (n > 0) {
            done += size_t(n), progress = Clock::now();
            continue;
        }
        if (n < 0 && errno == EINTR) continue;
        if (n == 0 || (errno != EAGAIN && errno != EWOULDBLOCK)) return false;
        // Socket buffer full: wait in short polls, up to the deadline or a stall.
        const auto now = Clock::now();
        if (now >= deadline || now - progress > kStallTimeout) return false;
        pollfd p{fd_, POLLOUT, 0};
        poll(&p, 1, 50);
    }
    return true;
}

bool TevStream::send_changed_tiles(Clock::time_point deadline) {
    const int w = image_w_, h = image_h_;
    // A new connection or image size: CreateImage, then every tile.
    if (created_w_ != w || created_h_ != h) {
        Message m(kCreateImage);
        m.u8(1);  // grab focus
        m.str(name_);
        m.i32(w), m.i32(h), m.i32(3);
        for (const char* c : kChannels) m.str(c);
        if (!send_all(m.done(), deadline)) return false;
        created_w_ = w, created_h_ = h;
        sent_valid_ = false;
    }
    if (!sent_valid_) sent_.assign(image_.size(), 0.0f);
    for (int y0 = 0; y0 < h; y0 += kTileSize)
        for (int x0 = 0; x0 < w; x0 += kTileSize) {
            const int tw = std::min(kTileSize, w - x0), th = std::min(kTileSize, h - y0);
            const size_t row_bytes = 3 * sizeof(float) * size_t(tw);
            const auto row = [&](int y) { return 3 * (size_t(y) * size_t(w) + size_t(x0)); };
            // Unchanged (bit for bit) since the last send on this connection: skip.
            bool same = sent_valid_;
            for (int y = y0; same && y < y0 + th; ++y)
                same = std::memcmp(&image_[row(y)], &sent_[row(y)], row_bytes) == 0;
            if (same) continue;
            // UpdateImage v3: RGB interleaved, offsets 0, 1, 2 and strides 3.
            Message m(kUpdateImage);
            m.bytes.reserve(128 + 3 * size_t(tw) * size_t(th) * 4);
            m.u8(0);  // grab focus
            m.str(name_);
            m.i32(3);
            for (const char* c : kChannels) m.str(c);
            m.i32(x0), m.i32(y0), m.i32(tw), m.i32(th);
            for (int c = 0; c < 3; ++c) m.i64(c);
            for (int c = 0; c < 3; ++c) m.i64(3);
            for (int y = y0; y < y0 + th; ++y)
                for (size_t i = 0; i < 3 * size_t(tw); ++i) m.f32(image_[row(y) + i]);
            if (!send_all(m.done(), deadline)) return false;
            for (int y = y0; y < y0 + th; ++y)
                std::memcpy(&sent_[row(y)], &image_[row(y)], row_bytes);
            std::lock_guard<std::mutex> lock(mutex_);
            ++stats_.tiles;
        }
    sent_valid_ = true;
    return true;
}

}  // namespace mcpt
