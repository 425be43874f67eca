// render --display-server and TevStream against a stand-in for tev that decodes its TCP
// protocol (CreateImage, UpdateImage v3), checking every length field: the streamed image is
// the written EXR float for float, only changed tiles are sent again, a restarted tev gets the
// whole image again, and a bad address fails before anything renders.
#include "common/view/tev_stream.h"

#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <cstring>
#include <filesystem>
#include <functional>
#include <map>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "common/error.h"
#include "common/io/image_io.h"
#include "test_util.h"

namespace mcpt {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

fs::path temp(const std::string& name) {
    return test::temp_file(name);
}

// Bounds-checked reads from one message's payload; the first failure names the field.
struct Reader {
    const unsigned char* p;
    size_t n, i = 0;
    std::string error;
    Reader(const unsigned char* data, size_t size) : p(data), n(size) {}
    bool take(size_t k, const char* what) {
        if (error.empty() && n - i < k) error = std::string("message too short for ") + what;
        return error.empty();
    }
    uint64_t le(size_t k, const char* what) {
        uint64_t v = 0;
        if (!take(k, what)) return 0;
        for (size_t b = 0; b < k; ++b) v |= uint64_t(p[i + b]) << (8 * b);
        i += k;
        return v;
    }
    int32_t i32(const char* what) { return int32_t(uint32_t(le(4, what))); }
    int64_t i64(const char* what) { return int64_t(le(8, what)); }
    float f32() {
        const uint32_t u = uint32_t(le(4, "pixel data"));
        float f;
        std::memcpy(&f, &u, 4);
        return f;
    }
    std::string str(const char* what) {
        const void* end = i < n ? std::memchr(p + i, 0, n - i) : nullptr;
        if (!end) {
            if (error.empty()) error = std::string("no NUL after ") + what;
            return "";
        }
        std::string s(reinterpret_cast<const char*>(p + i),
                      static_cast<const unsigned char*>(end) - (p + i));
        i += s.size() + 1;
        return s;
    }
    void fail(const std::string& why) {
        if (error.empty()) error = why;
    }
};

// A stand-in for tev on 127.0.0.1: accepts connections one after another and decodes them
// into float images. With drop_first: closes the first connection and its listening socket
// 0.1 s after the first UpdateImage (what follows it unread), and listens on the same port
// again 0.5 s later.
class FakeTev {
  public:
    struct Connection {
        std::string name;
        int width = 0, height = 0, creates = 0, updates = 0;
        std::vector<float> rgb;                    // NaN where no tile came
        std::map<std::pair<int, int>, int> tiles;  // (x, y) -> times received
        bool closed = false;
    };

    explicit FakeTev(bool drop_first = false) : drop_first_(drop_first) {
        listen_on(0);
        thread_ = std::thread([this] { serve(); });
    }
    ~FakeTev() {
        stop_ = true;
        thread_.join();
        if (listen_fd_ >= 0) close(listen_fd_);
    }
    int port() const { return port_; }
    std::string address() const { return "127.0.0.1:" + std::to_string(port_); }

    // Waits up to `timeout_s` until `pred` (called under the lock) holds.
    bool wait(const std::function<bool(const FakeTev&)>& pred, double timeout_s = 10) {
        std::unique_lock<std::mutex> lock(mutex_);
        return changed_.wait_for(lock, std::chrono::duration<double>(timeout_s), [&] {
            return pred(*this) || !error_.empty();
        }) && error_.empty();
    }
    // Copies, under the lock.
    std::vector<Connection> connections() const {
        std::lock_guard<std::mutex> lock(mutex_);
        return conns_;
    }
    std::string error() const {
        std::lock_guard<std::mutex> lock(mutex_);
        return error_;
    }
    bool dropped() const { return dropped_; }
    const std::vector<Connection>& conns() const { return conns_; }  // inside wait()'s pred

  private:
    void listen_on(int port) {
        listen_fd_ = socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
        const int one = 1;
        setsockopt(listen_fd_, SOL_SOCKET, SO_REUSEADDR, &one, sizeof(one));
        sockaddr_in a{};
        a.sin_family = AF_INET;
        a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
        a.sin_port = htons(uint16_t(port));
        socklen_t len = sizeof(a);
        if (bind(listen_fd_, reinterpret_cast<sockaddr*>(&a), sizeof(a)) != 0 ||
            listen(listen_fd_, 4) != 0 ||
            getsockname(listen_fd_, reinterpret_cast<sockaddr*>(&a), &len) != 0)
            throw Error("fake tev: cannot listen on port " + std::to_string(port));
        port_ = ntohs(a.sin_port);
    }

    void fail(const std::string& why) {
        std::lock_guard<std::mutex> lock(mutex_);
        if (error_.empty()) error_ = why;
        changed_.notify_all();
    }

    // Reads exactly n bytes in short polls; false on the end of the stream or stop.
    bool read_exact(int fd, unsigned char* buf, size_t n, size_t& got) {
        got = 0;
        while (got < n && !stop_) {
            pollfd p{fd, POLLIN, 0};
            if (poll(&p, 1, 50) <= 0) continue;
            const ssize_t r = recv(fd, buf + got, n - got, 0);
            if (r <= 0) return false;
            got += size_t(r);
        }
        return got == n;
    }

    void serve() {
        while (!stop_) {
            // Accept the next connection.
            pollfd p{listen_fd_, POLLIN, 0};
            if (poll(&p, 1, 50) <= 0) continue;
            const int fd = accept4(listen_fd_, nullptr, nullptr, SOCK_CLOEXEC);
            if (fd < 0) continue;
            {
                std::lock_guard<std::mutex> lock(mutex_);
                conns_.emplace_back();
            }
            const bool drop = decode(fd);
            close(fd);
            if (drop) close(listen_fd_), listen_fd_ = -1;
            {
                std::lock_guard<std::mutex> lock(mutex_);
                conns_.back().closed = true;
                dropped_ = dropped_ || drop;
                changed_.notify_all();
            }
            // tev restarts: no listener for 0.5 s, then the same port again.
            if (drop) {
                const auto until = Clock::now() + std::chrono::milliseconds(500);
                while (!stop_ && Clock::now() < until)
                    std::this_thread::sleep_for(std::chrono::milliseconds(10));
                listen_on(port_);
            }
        }
    }

    // Decodes messages until the end of the stream; true: drop this connection (drop_first).
    bool decode(int fd) {
        while (!stop_) {
            unsigned char head[4];
            size_t got = 0;
            if (!read_exact(fd, head, 4, got)) {
                if (got != 0) fail("stream ended inside a message's length");
                return false;
            }
            const uint32_t len = uint32_t(head[0]) | uint32_t(head[1]) << 8 |
                                 uint32_t(head[2]) << 16 | uint32_t(head[3]) << 24;
            if (len < 5 || len > (64u << 20)) {
                fail("bad message length " + std::to_string(len));
                return false;
            }
            std::vector<unsigned char> msg(len - 4);
            if (!read_exact(fd, msg.data(), msg.size(), got)) {
                fail("stream ended inside a message");
                return false;
            }
            const bool update = msg[0] == 6;
            if (!message(msg)) return false;
            if (update && drop_first_ && !dropped_) {
                std::this_thread::sleep_for(std::chrono::milliseconds(100));
                return true;
            }
        }
        return false;
    }

    // One message (type and payload); false on a protocol error.
    bool message(const std::vector<unsigned char>& msg) {
        Reader r(msg.data() + 1, msg.size() - 1);
        const int type = msg[0];
        if (type != 4 && type != 6) {
            fail("unexpected message type " + std::to_string(type));
            return false;
        }
        const uint64_t grab = r.le(1, "grab_focus");
        if (grab > 1) r.fail("grab_focus not 0 or 1");
        const std::string name = r.str("the image name");
        int w = 0, h = 0;
        if (type == 4) w = r.i32("width"), h = r.i32("height");
        const int32_t channels = r.i32("the channel count");
        if (channels != 3) r.fail("channel count " + std::to_string(channels) + ", not 3");
        for (const char* c : {"R", "G", "B"})
            if (r.error.empty() && r.str("a channel name") != c) r.fail("channels not R, G, B");
        std::lock_guard<std::mutex> lock(mutex_);
        Connection& conn = conns_.back();
        if (type == 4) {
            // CreateImage: nothing may follow the channel names.
            if (w < 1 || h < 1 || w > 16384 || h > 16384) r.fail("bad image size");
            if (r.error.empty() && r.i != r.n) r.fail("bytes after CreateImage");
            if (!r.error.empty()) return fail_locked("CreateImage: " + r.error);
            conn.name = name, conn.width = w, conn.height = h, ++conn.creates;
            conn.rgb.assign(3 * size_t(w) * size_t(h), std::nanf(""));
        } else {
            // UpdateImage v3: a tile inside the created image, interleaved RGB, exact length.
            const int x = r.i32("x"), y = r.i32("y"), tw = r.i32("tile width"),
                      th = r.i32("tile height");
            for (int c = 0; c < 3; ++c)
                if (r.i64("a channel offset") != c) r.fail("channel offsets not 0, 1, 2");
            for (int c = 0; c < 3; ++c)
                if (r.i64("a channel stride") != 3) r.fail("channel strides not 3");
            if (conn.creates == 0 || name != conn.name) r.fail("update of an image not created");
            if (x < 0 || y < 0 || tw < 1 || th < 1 || x + tw > conn.width || y + th > conn.height)
                r.fail("tile outside the image");
            if (r.error.empty() && r.n - r.i != 12 * size_t(tw) * size_t(th))
                r.fail("pixel data of " + std::to_string(r.n - r.i) + " bytes, not " +
                       std::to_string(12 * size_t(tw) * size_t(th)));
            if (!r.error.empty()) return fail_locked("UpdateImage: " + r.error);
            for (int j = 0; j < th; ++j)
                for (int i = 0; i < 3 * tw; ++i)
                    conn.rgb[3 * (size_t(y + j) * size_t(conn.width) + size_t(x)) + size_t(i)] =
                        r.f32();
            ++conn.updates, ++conn.tiles[{x, y}];
        }
        changed_.notify_all();
        return true;
    }
    bool fail_locked(const std::string& why) {
        if (error_.empty()) error_ = why;
        changed_.notify_all();
        return false;
    }

    const bool drop_first_;
    int listen_fd_ = -1, port_ = 0;
    std::atomic<bool> stop_{false}, dropped_{false};
    mutable std::mutex mutex_;
    std::condition_variable changed_;
    std::vector<Connection> conns_;
    std::string error_;
    std::thread thread_;
};

// Floats that differ bit for bit (NaN where nothing came is a difference).
size_t differing(const std::vector<float>& a, const std::vector<float>& b) {
    if (a.size() != b.size()) return std::max(a.size(), b.size());
    size_t n = 0;
    for (size_t i = 0; i < a.size(); ++i) n += std::memcmp(&a[i], &b[i], sizeof(float)) != 0;
    return n;
}

// A synthetic image (300x200: 6 tiles of at most 128x128), every float distinct.
std::vector<float> synthetic(int width = 300, int height = 200) {
    std::vector<float> img(3 * size_t(width) * size_t(height));
    for (size_t i = 0; i < img.size(); ++i) img[i] = 0.001f * float(i);
    return img;
}

// A streamed render: the last connection's decoded image and the EXR the run wrote.
struct Streamed {
    FakeTev::Connection conn;
    std::vector<float> exr;
    int width = 0, height = 0;
};

Streamed streamed_render(const std::string& args, const std::string& out) {
    Streamed s;
    FakeTev tev;
    fs::remove(out);
    const test::CliRun r = test::run_mcpt(
        "render cornell " + test::device_args("opencl") + " --width 160 --height 120 " + args +
        " --display-server " + tev.address() + " -o " + out + " -q");
    EXPECT_EQ(r.status, 0) << r.output;
    // The run has ended: its connection is closed once everything it sent is decoded.
    EXPECT_TRUE(
        tev.wait([](const FakeTev& t) { return !t.conns().empty() && t.conns()[0].closed; }, 10))
        << tev.error();
    const auto conns = tev.connections();
    EXPECT_EQ(conns.size(), 1u);
    if (!conns.empty()) s.conn = conns.back();
    if (r.status == 0) s.exr = read_exr(out, s.width, s.height);
    return s;
}

TEST(TevStream, StreamedImageEqualsTheWrittenExr) {
    // --time 1.5 with -q: render steps of 1 s, so an image is posted before the last.
    const std::string out = temp("streamed.exr").string();
    const Streamed s = streamed_render("--time 1.5", out);
    ASSERT_EQ(s.width, 160);
    ASSERT_EQ(s.height, 120);
    EXPECT_EQ(s.conn.name, "streamed.exr");
    EXPECT_EQ(s.conn.creates, 1);
    ASSERT_EQ(s.conn.width, 160);
    ASSERT_EQ(s.conn.height, 120);
    EXPECT_EQ(differing(s.conn.rgb, s.exr), 0u);
    // Two tiles (128 and 32 wide): more updates than tiles is more than one round.
    EXPECT_EQ(s.conn.tiles.size(), 2u);
    EXPECT_GT(s.conn.updates, 2) << "only the final round was streamed";
}

TEST(TevStream, StreamedImageDiffersFromAnotherSeedsExr) {
    // Negative control: the comparison above finds a render of another seed different.
    const Streamed s = streamed_render("--spp 16", temp("seed0.exr").string());
    ASSERT_EQ(differing(s.conn.rgb, s.exr), 0u);  // its own file: equal
    const std::string other = temp("seed5.exr").string();
    const test::CliRun r =
        test::run_mcpt("render cornell " + test::device_args("opencl") +
                       " --width 160 --height 120 --spp 16 --seed 5 -q -o " + other);
    ASSERT_EQ(r.status, 0) << r.output;
    int w = 0, h = 0;
    const std::vector<float> seed5 = read_exr(other, w, h);
    EXPECT_GT(differing(s.conn.rgb, seed5), seed5.size() / 2);
}

TEST(TevStream, OnlyChangedTilesAreSent) {
    FakeTev tev;
    TevStream stream(tev.address(), "synthetic");
    std::vector<float> img = synthetic();
    stream.post(300, 200, img);
    ASSERT_TRUE(tev.wait([](const FakeTev& t) {
        return !t.conns().empty() && t.conns()[0].updates == 6;
    })) << tev.error();
    // One pixel changed, at (200, 150): in the tile at (128, 128).
    img[3 * (150 * 300 + 200) + 1] += 1.0f;
    stream.post(300, 200, img);
    ASSERT_TRUE(stream.finish(5));
    ASSERT_TRUE(tev.wait([](const FakeTev& t) { return t.conns()[0].closed; })) << tev.error();
    const auto conns = tev.connections();
    ASSERT_EQ(conns.size(), 1u);
    const FakeTev::Connection& c = conns[0];
    EXPECT_EQ(c.creates, 1);
    EXPECT_EQ(c.updates, 7);
    EXPECT_EQ(c.tiles.size(), 6u);
    for (const auto& [xy, n] : c.tiles)
        EXPECT_EQ(n, xy == std::make_pair(128, 128) ? 2 : 1) << xy.first << "," << xy.second;
    EXPECT_EQ(differing(c.rgb, img), 0u);
    EXPECT_EQ(stream.stats().tiles, 7u);
}

TEST(TevStream, ReconnectsWhenTevRestarts) {
    // Three small tiles (128, 128 and 4 wide): the stream's first round fits the socket's
    // buffers, so it completes before tev goes away with two of them unread.
    FakeTev tev(/*drop_first=*/true);
    TevStream stream(tev.address(), "restart");
    std::vector<float> img = synthetic(260, 3);
    stream.post(260, 3, img);
    ASSERT_TRUE(tev.wait([](const FakeTev& t) { return t.dropped(); })) << tev.error();
    ASSERT_EQ(stream.stats().tiles, 3u);
    // One pixel changed: the new tev must still get every tile, not only that one.
    img[0] = -1.0f;
    stream.post(260, 3, img);
    ASSERT_TRUE(stream.finish(5));
    ASSERT_TRUE(tev.wait([](const FakeTev& t) {
        return t.conns().size() == 2 && t.conns()[1].closed;
    })) << tev.error();
    const auto conns = tev.connections();
    ASSERT_EQ(conns.size(), 2u);
    EXPECT_EQ(conns[0].updates, 1);  // dropped after its first tile
    EXPECT_EQ(conns[1].creates, 1);
    EXPECT_EQ(conns[1].tiles.size(), 3u);
    EXPECT_EQ(differing(conns[1].rgb, img), 0u);
    EXPECT_EQ(stream.stats().connections, 2u);
}

TEST(TevStream, WarnsOnceAndRetriesOnceASecondWhileUnreachable) {
    // A port nobody listens on: taken, then freed.
    int port = 0;
    {
        FakeTev gone;
        port = gone.port();
    }
    std::mutex m;
    std::vector<std::string> warnings;
    TevStream stream("127.0.0.1:" + std::to_string(port), "nobody", [&](const std::string& w) {
        std::lock_guard<std::mutex> lock(m);
        warnings.push_back(w);
    });
    stream.post(300, 200, synthetic());
    // Attempts at 0, 1, 2 s, spaced by the stream's own 1 s steady-clock timer (kRetryInterval):
    // fewer than 2 needs its thread >1.1 s late, more than 3 this one to oversleep by 0.9 s.
    std::this_thread::sleep_for(std::chrono::milliseconds(2100));
    const uint64_t attempts = stream.stats().attempts;
    EXPECT_GE(attempts, 2u);
    EXPECT_LE(attempts, 3u);
    const auto start = Clock::now();
    EXPECT_FALSE(stream.finish(0.2));
    EXPECT_LT(std::chrono::duration<double>(Clock::now() - start).count(), 1.5);
    std::lock_guard<std::mutex> lock(m);
    ASSERT_EQ(warnings.size(), 1u);
    EXPECT_EQ(warnings[0], "tev at 127.0.0.1:" + std::to_string(port) + " not reachable, retrying");
}

// A peer that reads 2 KiB every 0.1 s (progress, never a 2 s stall; a 192 KiB tile in 10 s)
// holds a message's send at most a few seconds: the stream gives the connection up and
// connects again.
TEST(TevStream, PeerThatTricklesIsGivenUp) {
    const int listener = socket(AF_INET, SOCK_STREAM, 0);
    ASSERT_GE(listener, 0);
    const int small = 4096;
    setsockopt(listener, SOL_SOCKET, SO_RCVBUF, &small, sizeof small);
    sockaddr_in addr{};
    addr.sin_family = AF_INET;
    addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    ASSERT_EQ(bind(listener, reinterpret_cast<sockaddr*>(&addr), sizeof addr), 0);
    ASSERT_EQ(listen(listener, 4), 0);
    socklen_t len = sizeof addr;
    getsockname(listener, reinterpret_cast<sockaddr*>(&addr), &len);
    std::atomic<bool> stop{false};
    std::atomic<int> accepted{0};
    std::thread peer([&] {
        std::vector<int> fds;
        while (!stop) {
            pollfd p{listener, POLLIN, 0};
            if (poll(&p, 1, 10) > 0) {
                const int fd = accept(listener, nullptr, nullptr);
                if (fd >= 0) fds.push_back(fd), ++accepted;
            }
            static auto last = Clock::now();
            if (Clock::now() - last < std::chrono::milliseconds(100)) continue;
            last = Clock::now();
            for (int fd : fds) {
                char bytes[2048];
                (void)recv(fd, bytes, sizeof bytes, MSG_DONTWAIT);
            }
        }
        for (int fd : fds) close(fd);
    });
    {
        TevStream stream("127.0.0.1:" + std::to_string(ntohs(addr.sin_port)), "trickle");
        stream.post(1024, 1024, std::vector<float>(size_t(3) << 20, 0.5f));
        const auto start = Clock::now();
        while (stream.stats().connections < 2 && Clock::now() - start < std::chrono::seconds(15))
            std::this_thread::sleep_for(std::chrono::milliseconds(50));
        EXPECT_GE(stream.stats().connections, 2u) << "the trickling peer held the stream";
        EXPECT_LT(std::chrono::duration<double>(Clock::now() - start).count(), 10.0);
    }
    stop = true;
    peer.join();
    close(listener);
}

TEST(TevStream, MalformedAddressFailsBeforeRendering) {
    const std::string out = temp("never.exr").string();
    const std::pair<const char*, const char*> cases[] = {
        {"nohost", "expected HOST:PORT"},
        {"127.0.0.1:99999", "port 99999 is out of range (1-65535)"},
        {"127.0.0.1:0", "out of range"},
        {"127.0.0.1:", "expected HOST:PORT"},
        {":14158", "expected HOST:PORT"},
        {"127.0.0.1:14x", "expected HOST:PORT"},
        {"::1:14158", "brackets"},
    };
    for (const auto& [address, message] : cases) {
        fs::remove(out);
        const test::CliRun r =
            test::run_mcpt("render cornell --width 16 --height 16 --spp 1 -q " +
                           std::string("--display-server ") + address + " -o " + out);
        EXPECT_EQ(r.status, 1) << address << "\n" << r.output;
        EXPECT_NE(r.output.find(message), std::string::npos) << address << "\n" << r.output;
        EXPECT_EQ(r.output.find("scene:"), std::string::npos) << "rendered: " << r.output;
        EXPECT_FALSE(fs::exists(out)) << address;
    }
    // The class itself, and an IPv6 literal in brackets that parses.
    EXPECT_THROW(TevStream("localhost", "x"), Error);
    EXPECT_NO_THROW(TevStream("[::1]:14158", "x"));
}

}  // namespace
}  // namespace mcpt
