#include "app/mpi_wire.h"

#ifdef MCPT_WITH_MPI
#include <algorithm>
#include <cmath>
#include <functional>
#include <thread>

#include "common/error.h"

namespace mcpt::wire {

namespace {

// Arrays in pieces below MPI's int count.
constexpr size_t kPiece = size_t(1) << 30;

struct ResultHeader {
    uint64_t first, spp, nonfinite_total, exact, width, height;
    double rays, seconds;
};

struct BatchHeader {
    uint64_t width, height, spp, nonfinite;
    double seconds, rays;
};

void send_bytes(const void* data, size_t bytes, int to, int tag = kResult) {
    const char* p = static_cast<const char*>(data);
    for (size_t at = 0; at < bytes; at += kPiece)
        MPI_Send(p + at, int(std::min(kPiece, bytes - at)), MPI_BYTE, to, tag, MPI_COMM_WORLD);
}

// Receives `bytes` from `from` as pieces of `tag`, each of exactly the size due; false when the
// deadline passes first. Called with the lock held.
bool receive_bytes(void* data, size_t bytes, int from, int tag, Clock::time_point deadline,
                   const std::function<Error(const MPI_Status&)>& unexpected) {
    char* p = static_cast<char*>(data);
    MPI_Status st;
    for (size_t at = 0; at < bytes; at += kPiece) {
        const int piece = int(std::min(kPiece, bytes - at));
        int flag = 0;
        while (MPI_Iprobe(from, MPI_ANY_TAG, MPI_COMM_WORLD, &flag, &st), !flag) {
            if (Clock::now() >= deadline) return false;
            std::this_thread::sleep_for(std::chrono::microseconds(200));
        }
        if (st.MPI_TAG != tag || count_of(st) != piece) throw unexpected(st);
        MPI_Recv(p + at, piece, MPI_BYTE, from, tag, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
    }
    return true;
}

// The error for a message of another tag or size than `what`, from `who`.
std::function<Error(const MPI_Status&)> unexpected_message(const std::string& who,
                                                           const char* what) {
    return [who, what](const MPI_Status& st) {
        return Error(who + " sent a message of tag " + std::to_string(st.MPI_TAG) + " and " +
                     std::to_string(count_of(st)) + " bytes where " + what + " was due");
    };
}

// Waits up to `deadline` for `from`'s next message and receives it as a header of `tag` and
// exactly `bytes` bytes; the lock, taken for it, is handed back for the arrays that follow
// (not owned: nothing came in time). A kError is thrown as its exception, anything else as
// unexpected(st).
std::unique_lock<std::mutex> receive_header(
    int from, int tag, void* header, size_t bytes, Clock::time_point deadline,
    const std::function<Error(const MPI_Status&)>& unexpected) {
    MPI_Status st;
    if (!wait_for(from, deadline, st)) return {};
    std::unique_lock<std::mutex> hold(lock());
    if (st.MPI_TAG == kError) throw_rank_error(from, st);
    if (st.MPI_TAG != tag || count_of(st) != int(bytes)) throw unexpected(st);
    MPI_Recv(header, int(bytes), MPI_BYTE, from, tag, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
    return hold;
}

}  // namespace

std::mutex& lock() {
    static std::mutex m;
    return m;
}

std::string rank_name(int rank) {
    return "rank " + std::to_string(rank);
}

bool wait_for(int rank, Clock::time_point deadline, MPI_Status& st) {
    for (;;) {
        {
            std::lock_guard<std::mutex> hold(lock());
            int flag = 0;
            MPI_Iprobe(rank, MPI_ANY_TAG, MPI_COMM_WORLD, &flag, &st);
            if (flag) return true;
        }
        if (Clock::now() >= deadline) return false;
        std::this_thread::sleep_for(std::chrono::microseconds(200));
    }
}

int count_of(const MPI_Status& st) {
    int n = 0;
    MPI_Get_count(&st, MPI_BYTE, &n);
    return n;
}

std::string receive_text(int rank, const MPI_Status& st) {
    const int n = count_of(st);
    if (n < 0 || n > kMaxText)
        throw Error(rank_name(rank) + " sent a message of " + std::to_string(n) +
                    " bytes where at most " + std::to_string(kMaxText) + " are taken");
    std::string text(size_t(std::max(n, 1)), '\0');
    MPI_Recv(text.data(), n, MPI_BYTE, rank, st.MPI_TAG, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
    text.resize(size_t(n));
    return text;
}

void throw_rank_error(int rank, const MPI_Status& st) {
    std::string why = receive_text(rank, st);
    const bool lost = !why.empty() && why[0] == 1;
    if (!why.empty()) why.erase(0, 1);
    if (lost) throw DeviceLost(why);
    throw Error(why);
}

void send_error(const std::exception& e, bool lost) {
    const std::string why = std::string(1, lost ? '\1' : '\0') + e.what();
    MPI_Send(why.data(), int(std::min<size_t>(why.size(), kMaxText)), MPI_BYTE, 0, kError,
             MPI_COMM_WORLD);
}

void send_sums(const RenderResult& r, int to, bool bad_size) {
    const ResultHeader h{r.first,
                         r.spp,
                         r.nonfinite_total,
                         r.exact.empty() ? 0u : 1u,
                         uint64_t(r.width) + (bad_size ? 1u : 0u),
                         uint64_t(r.height),
                         r.rays,
                         r.seconds};
    MPI_Send(&h, sizeof h, MPI_BYTE, to, kResult, MPI_COMM_WORLD);
    if (r.spp == 0) return;
    if (!r.exact.empty()) {
        send_bytes(r.exact.data(), r.exact.size() * sizeof(ExactSum), to);
    } else {
        send_bytes(r.sum.data(), r.sum.size() * sizeof(double), to);
        send_bytes(r.sum_sq.data(), r.sum_sq.size() * sizeof(double), to);
    }
    send_bytes(r.nonfinite.data(), r.nonfinite.size() * sizeof(double), to);
}

bool receive_sums(int from, const SumsShape& shape, uint64_t spp, Clock::time_point deadline,
                  const std::string& who, RenderResult& out) {
    const auto unexpected = unexpected_message(who, "the round's sums");
    const auto bad = [&](const std::string& what) {
        return Error(who + " sent sums that do not fit the job: " + what);
    };
    // The header: exactly its size, this job's image and kind of sums, and exactly the
    // samples handed out to the ranks it speaks for (a subtree that lost a rank's sums, or
    // added one twice, is named here).
    ResultHeader h{};
    const auto hold = receive_header(from, kResult, &h, sizeof h, deadline, unexpected);
    if (!hold.owns_lock()) return false;
    const uint64_t n = uint64_t(shape.width) * uint64_t(shape.height);
    // (A rank that rendered nothing this round holds no image: 0x0.)
    const bool empty = h.spp == 0 && h.width == 0 && h.height == 0;
    if (!empty && (h.width != uint64_t(shape.width) || h.height != uint64_t(shape.height)))
        throw bad(std::to_string(h.width) + "x" + std::to_string(h.height) +
                  " pixels, the image is " + std::to_string(shape.width) + "x" +
                  std::to_string(shape.height));
    if (spp != kAnySpp && h.spp != spp)
        throw bad(std::to_string(h.spp) + " samples per pixel, " + std::to_string(spp) +
                  " were handed out");
    if (h.spp > 0 && h.exact != (shape.exact ? 1u : 0u))
        throw bad(h.exact ? "exact sums in a job without them"
                          : "no exact sums in a reproducible job");
    if (!(h.rays >= 0 && h.rays < 1e30 && h.seconds >= 0 && h.seconds < 1e12) ||
        (h.spp > 0 && h.nonfinite_total / h.spp > n))
        throw bad("counts out of range");
    // (The arrays keep the memory of the last round's: no page is faulted in again.)
    out.width = shape.width, out.height = shape.height;
    out.first = 0, out.spp = 0, out.rays = 0, out.seconds = 0, out.nonfinite_total = 0;
    out.samples.clear();
    if (h.spp == 0) return true;
    out.first = h.first, out.spp = h.spp, out.nonfinite_total = h.nonfinite_total;
    out.rays = h.rays, out.seconds = h.seconds;
    out.sum.resize(3 * n), out.sum_sq.resize(3 * n), out.nonfinite.resize(n);
    out.exact.resize(shape.exact ? 6 * n : 0);
    // The arrays, each piece of exactly the size due.
    const auto receive = [&](void* data, size_t bytes) {
        return receive_bytes(data, bytes, from, kResult, deadline, unexpected);
    };
    if (shape.exact) {
        if (!receive(out.exact.data(), out.exact.size() * sizeof(ExactSum))) return false;
    } else {
        if (!receive(out.sum.data(), out.sum.size() * sizeof(double))) return false;
        if (!receive(out.sum_sq.data(), out.sum_sq.size() * sizeof(double))) return false;
    }
    return receive(out.nonfinite.data(), out.nonfinite.size() * sizeof(double));
}

void send_batch_mean(const BatchMean& b, bool bad_size) {
    const BatchHeader h{uint64_t(b.width) + (bad_size ? 1u : 0u), uint64_t(b.height), b.spp,
                        b.nonfinite, b.seconds, b.rays};
    MPI_Send(&h, sizeof h, MPI_BYTE, 0, kBatchMean, MPI_COMM_WORLD);
    send_bytes(b.mean.data(), b.mean.size() * sizeof(double), 0, kBatchMean);
}

bool receive_batch_mean(int from, int width, int height, uint64_t spp,
                        Clock::time_point deadline, const std::string& who, BatchMean& out) {
    const auto unexpected = unexpected_message(who, "a batch");
    const auto bad = [&](const std::string& what) {
        return Error(who + " sent a batch that does not fit the job: " + what);
    };
    BatchHeader h{};
    const auto hold = receive_header(from, kBatchMean, &h, sizeof h, deadline, unexpected);
    if (!hold.owns_lock()) return false;
    // The header: this image, the samples asked for, counts in range.
    const uint64_t n = uint64_t(width) * uint64_t(height);
    if (h.width != uint64_t(width) || h.height != uint64_t(height))
        throw bad(std::to_string(h.width) + "x" + std::to_string(h.height) +
                  " pixels, the image is " + std::to_string(width) + "x" + std::to_string(height));
    if (h.spp != spp)
        throw bad(std::to_string(h.spp) + " samples per pixel, " + std::to_string(spp) +
                  " were asked for");
    if (!(h.rays >= 0 && h.rays < 1e30 && h.seconds >= 0 && h.seconds < 1e12) ||
        h.nonfinite / std::max<uint64_t>(spp, 1) > n)
        throw bad("counts out of range");
    out = BatchMean{};
    out.width = width, out.height = height;
    out.spp = h.spp, out.nonfinite = h.nonfinite, out.seconds = h.seconds, out.rays = h.rays;
    out.mean.resize(n);
    if (!receive_bytes(out.mean.data(), n * sizeof(double), from, kBatchMean, deadline,
                       unexpected))
        return false;
    // A mean is finite: non-finite samples are counted, never added.
    for (double m : out.mean)
        if (!std::isfinite(m)) throw bad("a mean that is not finite");
    return true;
}

}  // namespace mcpt::wire
#endif
