#include "app/view/guarded_server.h"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <strings.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <condition_variable>
#include <cstdlib>
#include <cstring>
#include <deque>
#include <functional>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

namespace mcpt {

namespace {

using Clock = std::chrono::steady_clock;

// Set on the thread that runs a connection the pool has no room for: it is answered 503.
thread_local bool t_reject = false;

// A fixed pool of threads and a bounded queue. A connection beyond the queue runs at once on
// the accepting thread, marked to be refused (a write of a few bytes, then close).
class BoundedPool : public httplib::TaskQueue {
  public:
    BoundedPool(size_t threads, size_t queued) : max_queued_(queued) {
        for (size_t i = 0; i < threads; ++i) threads_.emplace_back([this] { work(); });
    }
    void enqueue(std::function<void()> fn) override {
        {
            std::lock_guard<std::mutex> lock(mutex_);
            if (jobs_.size() < max_queued_) {
                jobs_.push_back(std::move(fn));
                ready_.notify_one();
                return;
            }
        }
        t_reject = true;
        fn();
        t_reject = false;
    }
    void shutdown() override {
        {
            std::lock_guard<std::mutex> lock(mutex_);
            stopping_ = true;
        }
        ready_.notify_all();
        for (std::thread& t : threads_) t.join();
    }

  private:
    void work() {
        for (;;) {
            std::function<void()> fn;
            {
                std::unique_lock<std::mutex> lock(mutex_);
                ready_.wait(lock, [&] { return stopping_ || !jobs_.empty(); });
                if (jobs_.empty()) return;
                fn = std::move(jobs_.front());
                jobs_.pop_front();
            }
            fn();
        }
    }
    size_t max_queued_;
    std::vector<std::thread> threads_;
    std::deque<std::function<void()>> jobs_;
    std::mutex mutex_;
    std::condition_variable ready_;
    bool stopping_ = false;
};

// A connection's socket as httplib's Stream: reads through a buffer, within a budget (the
// request head checked, plus its body) and deadlines; every wait in short polls that end when
// the server closes its connections.
class GuardedStream : public httplib::Stream {
  public:
    GuardedStream(int fd, const GuardLimits& limits, const std::atomic<bool>& closing)
        : fd_(fd), limits_(limits), closing_(closing) {}

    enum class Head { Ready, Closed, TooLarge, TooManyLines, TimedOut };

    // Reads until the buffer holds a whole request head (up to the line that is only CRLF, as
    // httplib ends it), within the limits and `timeout`; sets the read budget to that head.
    Head read_head(std::chrono::milliseconds timeout, size_t& head_size) {
        const auto deadline = Clock::now() + timeout;
        size_t scanned = pos_;
        for (;;) {
            // httplib's head ends at a line that is exactly CRLF after a line end.
            const size_t from = scanned > pos_ + 1 ? scanned - 2 : pos_;
            const size_t end = buf_.find("\n\r\n", from);
            if (end != std::string::npos && end + 3 - pos_ <= limits_.head_bytes) {
                head_size = end + 3 - pos_;
                const size_t lines = size_t(
                    std::count(buf_.begin() + long(pos_), buf_.begin() + long(end + 3), '\n'));
                if (lines > limits_.head_lines + 2) return Head::TooManyLines;  // + request, end
                budget_ = head_size;
                return Head::Ready;
            }
            scanned = buf_.size();
            if (buf_.size() - pos_ > limits_.head_bytes) return Head::TooLarge;
            if (std::count(buf_.begin() + long(pos_), buf_.end(), '\n') >
                long(limits_.head_lines + 2))
                return Head::TooManyLines;
            const int got = fill(deadline);
            if (got == 0) return buf_.size() > pos_ ? Head::TimedOut : Head::Closed;
            if (got < 0) return Head::TimedOut;
        }
    }
    // The head read_head() found.
    std::string head(size_t size) const { return buf_.substr(pos_, size); }
    // The request's body may follow its head (what the budget allows after it).
    void allow_body(size_t bytes) { budget_ += bytes; }
    // Drops what was read of this request (the rest of the buffer is the next one's).
    void next_request() { budget_ = 0; }

    bool is_readable() const override { return pos_ < buf_.size() || wait(POLLIN, 0) > 0; }
    bool is_writable() const override { return !closing_.load() && wait(POLLOUT, 0) >= 0; }

    ssize_t read(char* ptr, size_t size) override {
        if (budget_ == 0) return 0;  // beyond what was checked: the end of the stream
        if (pos_ == buf_.size()) {
            compact();
            const int got = fill(Clock::now() + limits_.idle_timeout);
            if (got <= 0) return got == 0 ? 0 : -1;
        }
        const size_t n = std::min({size, buf_.size() - pos_, budget_});
        std::memcpy(ptr, buf_.data() + pos_, n);
        pos_ += n, budget_ -= n;
        return ssize_t(n);
    }

    ssize_t write(const char* ptr, size_t size) override {
        const auto deadline = Clock::now() + limits_.write_timeout;
        size_t done = 0;
        while (done < size) {
            const ssize_t n = ::send(fd_, ptr + done, size - done, MSG_NOSIGNAL | MSG_DONTWAIT);
            if (n > 0) {
                done += size_t(n);
                continue;
            }
            if (n < 0 && errno == EINTR) continue;
            if (n == 0 || (errno != EAGAIN && errno != EWOULDBLOCK)) return -1;
            if (!wait_until(POLLOUT, deadline)) return -1;
        }
        return ssize_t(size);
    }

    void get_remote_ip_and_port(std::string& ip, int& port) const override {
        address(getpeername, ip, port);
    }
    void get_local_ip_and_port(std::string& ip, int& port) const override {
        address(getsockname, ip, port);
    }
    socket_t socket() const override { return fd_; }

    // A response written by the guard itself (the request refused before httplib saw it).
    void refuse(int status, const char* reason, const std::string& text) {
        const std::string body = text + "\n";
        const std::string msg =
            "HTTP/1.1 " + std::to_string(status) + " " + reason +
            "\r\nContent-Type: text/plain\r\nContent-Length: " + std::to_string(body.size()) +
            "\r\nConnection: close\r\n\r\n" + body;
        write(msg.data(), msg.size());
    }

  private:
    // poll() for `events` up to `ms` (0: now): > 0 ready, 0 not, < 0 error or hang-up.
    int wait(short events, int ms) const {
        pollfd p{fd_, events, 0};
        const int rc = poll(&p, 1, ms);
        if (rc > 0 && (p.revents & (POLLERR | POLLNVAL))) return -1;
        return rc;
    }
    // Waits in short polls until ready, the deadline, or the server closing.
    bool wait_until(short events, Clock::time_point deadline) const {
        while (!closing_.load()) {
            const auto left =
                std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now());
            if (left.count() <= 0) return false;
            const int rc = wait(events, int(std::min<long long>(left.count(), 100)));
            if (rc != 0) return rc > 0;
        }
        return false;
    }
    // Appends what the socket has, waiting up to the deadline: bytes read, 0 at the end of the
    // stream, -1 on a timeout or an error.
    int fill(Clock::time_point deadline) {
        if (!wait_until(POLLIN, deadline)) return -1;
        char chunk[4096];
        for (;;) {
            const ssize_t n = ::recv(fd_, chunk, sizeof chunk, MSG_DONTWAIT);
            if (n < 0 && errno == EINTR) continue;
            if (n < 0) return -1;
            buf_.append(chunk, size_t(n));
            return int(n);
        }
    }
    void compact() {
        if (pos_ > 0) buf_.erase(0, pos_), pos_ = 0;
    }
    void address(int (*get)(int, sockaddr*, socklen_t*), std::string& ip, int& port) const {
        sockaddr_storage a{};
        socklen_t len = sizeof a;
        ip.clear(), port = 0;
        if (get(fd_, reinterpret_cast<sockaddr*>(&a), &len) != 0) return;
        char text[INET6_ADDRSTRLEN] = "";
        if (a.ss_family == AF_INET) {
            const auto* v4 = reinterpret_cast<const sockaddr_in*>(&a);
            inet_ntop(AF_INET, &v4->sin_addr, text, sizeof text);
            port = ntohs(v4->sin_port);
        } else if (a.ss_family == AF_INET6) {
            const auto* v6 = reinterpret_cast<const sockaddr_in6*>(&a);
            inet_ntop(AF_INET6, &v6->sin6_addr, text, sizeof text);
            port = ntohs(v6->sin6_port);
        }
        ip = text;
    }

    int fd_;
    const GuardLimits& limits_;
    const std::atomic<bool>& closing_;
    std::string buf_;
    size_t pos_ = 0;     // the first byte not yet taken
    size_t budget_ = 0;  // bytes httplib may still take: the checked head and its body
};

// A header's value in a raw request head ("" when absent), names compared without case.
std::string header_value(const std::string& head, const char* name) {
    const size_t n = std::strlen(name);
    size_t at = head.find('\n');
    while (at != std::string::npos && at + 1 < head.size()) {
        const size_t start = at + 1, end = head.find('\n', start);
        const std::string line = head.substr(start, end == std::string::npos ? end : end - start);
        if (line.size() > n && line[n] == ':' && strncasecmp(line.c_str(), name, n) == 0) {
            std::string v = line.substr(n + 1);
            v.erase(0, v.find_first_not_of(" \t"));
            v.erase(v.find_last_not_of(" \t\r") + 1);
            return v;
        }
        at = end;
    }
    return "";
}

}  // namespace

GuardedServer::GuardedServer(GuardLimits limits) : limits_(limits) {
    new_task_queue = [this] { return new BoundedPool(limits_.threads, limits_.queued); };
    // SO_REUSEADDR alone (a restart binds over TIME_WAIT); no SO_REUSEPORT: a port in use is
    // an error, not shared.
    set_socket_options([](socket_t sock) {
        const int yes = 1;
        setsockopt(sock, SOL_SOCKET, SO_REUSEADDR, &yes, sizeof yes);
    });
    set_keep_alive_max_count(size_t(limits_.requests_per_connection));
    set_payload_max_length(limits_.body_bytes);
}

bool GuardedServer::process_and_close_socket(socket_t sock) {
    GuardedStream stream(sock, limits_, closing_);
    const auto finish = [&](bool ok) {
        ::shutdown(sock, SHUT_RDWR);
        ::close(sock);
        return ok;
    };
    if (t_reject) {
        stream.refuse(503, "Service Unavailable", "busy: too many connections");
        return finish(false);
    }
    for (int n = 0; n < limits_.requests_per_connection && !closing_.load(); ++n) {
        size_t head_size = 0;
        switch (stream.read_head(n == 0 ? limits_.head_timeout : limits_.idle_timeout, head_size)) {
            case GuardedStream::Head::Ready:
                break;
            case GuardedStream::Head::Closed:
                return finish(true);
            case GuardedStream::Head::TooLarge:
                stream.refuse(431, "Request Header Fields Too Large",
                              "request head over " + std::to_string(limits_.head_bytes) + " bytes");
                return finish(false);
            case GuardedStream::Head::TooManyLines:
                stream.refuse(431, "Request Header Fields Too Large",
                              "over " + std::to_string(limits_.head_lines) + " header lines");
                return finish(false);
            case GuardedStream::Head::TimedOut:
                stream.refuse(408, "Request Timeout", "request head not received in time");
                return finish(false);
        }
        // The head as httplib will read it: no chunked bodies, none over the limit.
        const std::string head = stream.head(head_size);
        const std::string length = header_value(head, "Content-Length");
        if (!header_value(head, "Transfer-Encoding").empty()) {
            stream.refuse(501, "Not Implemented",
                          "no request bodies in chunks (Transfer-Encoding)");
            return finish(false);
        }
        char* tail = nullptr;
        const unsigned long long body =
            length.empty() ? 0 : std::strtoull(length.c_str(), &tail, 10);
        if (!length.empty() && (tail == length.c_str() || *tail != '\0' || length[0] == '-' ||
                                body > limits_.body_bytes)) {
            stream.refuse(
                413, "Payload Too Large",
                "request bodies of at most " + std::to_string(limits_.body_bytes) + " bytes");
            return finish(false);
        }
        stream.allow_body(size_t(body));
        bool closed = false;
        const bool ok =
            process_request(stream, n + 1 == limits_.requests_per_connection, closed, nullptr);
        stream.next_request();
        if (!ok || closed) break;
    }
    return finish(true);
}

}  // namespace mcpt
