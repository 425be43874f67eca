#include "app/mpi_job.h"

#include <chrono>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <mutex>
#include <thread>

#include "common/error.h"
#include "common/render/device_registry.h"

#ifdef MCPT_WITH_MPI
#include <mpi.h>
#endif

namespace mcpt {

namespace {
MpiJob g_job;
}  // namespace

const MpiJob& mpi_job() {
    return g_job;
}

std::string rank_device(const std::string& backend, const MpiJob& job) {
    if (job.size <= 1) return backend;
    std::vector<DeviceInfo> gpus;
    for (const DeviceInfo& d : list_devices(backend))
        if (d.type == "gpu") gpus.push_back(d);
    if (gpus.empty()) return backend;
    return backend + ":" + std::to_string(gpus[size_t(job.local_rank) % gpus.size()].index);
}

#ifndef MCPT_WITH_MPI

const MpiJob& mpi_start(int&, char**&) {
    // Under mpirun, N copies of a build without MPI would each render the whole image.
    const char* size = std::getenv("OMPI_COMM_WORLD_SIZE");
    if (!size) size = std::getenv("PMI_SIZE");
    if (size && std::atoi(size) > 1)
        throw Error(
            "started by mpirun, but this mcpt was built without MPI "
            "(install libopenmpi-dev and build again)");
    return g_job;
}
void mpi_finish() {}
void mpi_abort(int code) {
    std::exit(code);
}
std::vector<std::unique_ptr<Worker>> mpi_remote_workers(const Fingerprint&, const RankJob&) {
    return {};
}
void mpi_serve(Session&) {}

#else

namespace {

// Messages between rank 0 and the others.
enum Tag : int {
    kHello = 1,   // rank -> 0: its device's name, a newline, its job's fingerprint
    kChunk = 2,   // 0 -> rank: first, end (end 0: stop)
    kDone = 3,    // rank -> 0: the chunk is rendered
    kRound = 4,   // 0 -> rank: send the round's sums
    kResult = 5,  // rank -> 0: the round's sums (header, then arrays)
    kError = 6,   // rank -> 0: why it failed (first byte 1: its device was lost)
};

// The longest hello or error message rank 0 takes.
constexpr int kMaxText = 1 << 16;

bool g_started = false;  // MPI_Init done

// MPI calls from several threads of rank 0 (MPI_THREAD_SERIALIZED): one at a time.
std::mutex g_mpi;

using Clock = std::chrono::steady_clock;

// Arrays in pieces below MPI's int count.
constexpr size_t kPiece = size_t(1) << 30;

void send_bytes(const void* data, size_t bytes, int to, int tag) {
    const char* p = static_cast<const char*>(data);
    for (size_t at = 0; at < bytes; at += kPiece)
        MPI_Send(p + at, int(std::min(kPiece, bytes - at)), MPI_BYTE, to, tag, MPI_COMM_WORLD);
}

struct ResultHeader {
    uint64_t first, spp, nonfinite_total, exact, width, height;
    double rays, seconds;
};

std::string rank_name(int rank) {
    return "rank " + std::to_string(rank);
}

// Waits for the next message from `rank` without holding the lock (other ranks' threads go
// on), up to `deadline`; false when none came by then.
bool wait_for(int rank, Clock::time_point deadline, MPI_Status& st) {
    for (;;) {
        {
            std::lock_guard<std::mutex> lock(g_mpi);
            int flag = 0;
            MPI_Iprobe(rank, MPI_ANY_TAG, MPI_COMM_WORLD, &flag, &st);
            if (flag) return true;
        }
        if (Clock::now() >= deadline) return false;
        std::this_thread::sleep_for(std::chrono::microseconds(500));
    }
}

// The byte count of a probed message.
int count_of(const MPI_Status& st) {
    int n = 0;
    MPI_Get_count(&st, MPI_BYTE, &n);
    return n;
}

// Receives a probed text message of at most kMaxText bytes (longer: refused unread... then
// received into nothing, the job ends anyway).
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

// A rank's failure message as the exception it stands for.
[[noreturn]] void throw_rank_error(int rank, const MPI_Status& st) {
    std::string why = receive_text(rank, st);
    const bool lost = !why.empty() && why[0] == 1;
    if (!why.empty()) why.erase(0, 1);
    if (lost) throw DeviceLost(why);
    throw Error(why);
}

class RankWorker : public Worker {
  public:
    RankWorker(int rank, std::string device, const RankJob& job)
        : rank_(rank), device_(std::move(device)), job_(job) {}
    ~RankWorker() override {
        // The job is over: this rank may exit.
        if (stopped_) return;
        std::lock_guard<std::mutex> lock(g_mpi);
        const uint64_t stop[2] = {0, 0};
        MPI_Send(stop, 2, MPI_UINT64_T, rank_, kChunk, MPI_COMM_WORLD);
    }
    std::string name() const override { return device_ + " (" + rank_name(rank_) + ")"; }
    std::string device_name() const override { return device_; }
    void render(const Chunk& chunk) override {
        {
            std::lock_guard<std::mutex> lock(g_mpi);
            const uint64_t range[2] = {chunk.first, chunk.end};
            MPI_Send(range, 2, MPI_UINT64_T, rank_, kChunk, MPI_COMM_WORLD);
        }
        // A deadline from this rank's measured speed: ten times the chunk's expected time,
        // and never less than the job's floor (the first chunk has no measurement).
        const double samples = double(chunk.end - chunk.first);
        const double expected = rate_ > 0 ? samples / rate_ : 0;
        const double allowed = std::max(job_.timeout_floor_s, 10 * expected);
        const auto start = Clock::now();
        MPI_Status st;
        if (!wait_for(rank_, start + to_duration(allowed), st))
            hung("samples " + std::to_string(chunk.first) + "-" + std::to_string(chunk.end),
                 allowed, expected, false);
        std::lock_guard<std::mutex> lock(g_mpi);
        if (st.MPI_TAG == kError) {
            stopped_ = true;  // it has left the job
            throw_rank_error(rank_, st);
        }
        if (st.MPI_TAG != kDone || count_of(st) != 0) unexpected(st, "the end of a chunk", false);
        MPI_Recv(nullptr, 0, MPI_BYTE, rank_, kDone, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
        const double took = std::chrono::duration<double>(Clock::now() - start).count();
        if (took > 0) rate_ = samples / took;
        round_spp_ += chunk.end - chunk.first;
    }
    void add_round_to(RenderResult& total) override {
        const uint64_t handed = round_spp_;
        round_spp_ = 0;
        const size_t n = size_t(job_.width) * size_t(job_.height);
        const size_t arrays =
            job_.exact ? 6 * n * sizeof(ExactSum) + n * sizeof(double) : 7 * n * sizeof(double);
        // The floor, and the arrays at 50 MB/s at least.
        const double allowed = job_.timeout_floor_s + double(arrays) / 50e6;
        const auto deadline = Clock::now() + to_duration(allowed);
        {
            std::lock_guard<std::mutex> lock(g_mpi);
            MPI_Send(nullptr, 0, MPI_BYTE, rank_, kRound, MPI_COMM_WORLD);
        }
        // The header: exactly its size, this job's image and kind of sums, no more samples
        // than were handed to this rank this round.
        MPI_Status st;
        if (!wait_for(rank_, deadline, st)) hung("the round's sums", allowed, 0, true);
        std::lock_guard<std::mutex> lock(g_mpi);
        if (st.MPI_TAG == kError) {
            stopped_ = true;
            throw_rank_error(rank_, st);
        }
        if (st.MPI_TAG != kResult || count_of(st) != int(sizeof(ResultHeader)))
            unexpected(st, "the round's sums", true);
        ResultHeader h{};
        MPI_Recv(&h, sizeof h, MPI_BYTE, rank_, kResult, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
        const auto bad = [&](const std::string& what) {
            stopped_ = true;
            throw Error(who(true) + "sent sums that do not fit the job: " + what);
        };
        if (h.width != uint64_t(job_.width) || h.height != uint64_t(job_.height))
            bad(std::to_string(h.width) + "x" + std::to_string(h.height) +
                " pixels, the image is " + std::to_string(job_.width) + "x" +
                std::to_string(job_.height));
        if (h.spp > handed)
            bad(std::to_string(h.spp) + " samples per pixel, " + std::to_string(handed) +
                " were handed to it");
        if (h.spp > 0 && h.exact != (job_.exact ? 1u : 0u))
            bad(h.exact ? "exact sums in a job without them"
                        : "no exact sums in a reproducible job");
        if (!(h.rays >= 0 && h.rays < 1e30 && h.seconds >= 0 && h.seconds < 1e12) ||
            h.nonfinite_total > h.spp * n)
            bad("counts out of range");
        if (h.spp == 0) return;
        RenderResult r;
        r.width = job_.width, r.height = job_.height;
        r.first = h.first, r.spp = h.spp, r.nonfinite_total = h.nonfinite_total;
        r.rays = h.rays, r.seconds = h.seconds;
        r.sum.resize(3 * n), r.sum_sq.resize(3 * n), r.nonfinite.resize(n);
        r.exact.resize(job_.exact ? 6 * n : 0);
        if (job_.exact) {
            receive(r.exact.data(), r.exact.size() * sizeof(ExactSum), deadline, allowed);
        } else {
            receive(r.sum.data(), r.sum.size() * sizeof(double), deadline, allowed);
            receive(r.sum_sq.data(), r.sum_sq.size() * sizeof(double), deadline, allowed);
        }
        receive(r.nonfinite.data(), r.nonfinite.size() * sizeof(double), deadline, allowed);
        accumulate_sums(total, r);
    }

  private:
    static Clock::duration to_duration(double seconds) {
        return std::chrono::duration_cast<Clock::duration>(
            std::chrono::duration<double>(std::min(seconds, 1e9)));
    }
    // "rank 2 (opencl: ...)": errors of render() are named by the coordinator, those of
    // add_round_to() here.
    std::string who(bool named) const {
        return named ? rank_name(rank_) + " (" + device_ + ") " : "";
    }
    // The rank did not answer in time: it is hung or stopped; the job ends naming it.
    [[noreturn]] void hung(const std::string& what, double allowed, double expected, bool named) {
        stopped_ = true;
        char text[160];
        std::snprintf(text, sizeof text,
                      "did not deliver %s within %.1f s (expected %.2f s at its measured speed): "
                      "hung or stopped",
                      what.c_str(), allowed, expected);
        throw Error(who(named) + text);
    }
    [[noreturn]] void unexpected(const MPI_Status& st, const std::string& what, bool named) {
        stopped_ = true;
        throw Error(who(named) + "sent a message of tag " + std::to_string(st.MPI_TAG) + " and " +
                    std::to_string(count_of(st)) + " bytes where " + what + " was due");
    }
    // Arrays in pieces (the lock held), each of exactly the size due.
    void receive(void* data, size_t bytes, Clock::time_point deadline, double allowed) {
        char* p = static_cast<char*>(data);
        for (size_t at = 0; at < bytes; at += kPiece) {
            const int piece = int(std::min(kPiece, bytes - at));
            MPI_Status st;
            int flag = 0;
            for (;;) {
                MPI_Iprobe(rank_, MPI_ANY_TAG, MPI_COMM_WORLD, &flag, &st);
                if (flag) break;
                if (Clock::now() >= deadline) hung("the round's sums", allowed, 0, true);
                std::this_thread::sleep_for(std::chrono::microseconds(200));
            }
            if (st.MPI_TAG != kResult || count_of(st) != piece)
                unexpected(st, "the round's sums", true);
            MPI_Recv(p + at, piece, MPI_BYTE, rank_, kResult, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
        }
    }

    int rank_;
    std::string device_;
    RankJob job_;
    bool stopped_ = false;
    double rate_ = 0;         // samples per pixel per second in its last chunk; 0: unknown
    uint64_t round_spp_ = 0;  // handed to it (and done) since the last round
};

void send_error(const std::exception& e, bool lost) {
    const std::string why = std::string(1, lost ? '\1' : '\0') + e.what();
    MPI_Send(why.data(), int(std::min<size_t>(why.size(), kMaxText)), MPI_BYTE, 0, kError,
             MPI_COMM_WORLD);
}

// Fault injection for tests (MCPT_MPI_FAULT_RANK, MCPT_MPI_FAULT_AFTER_ROUNDS): this rank,
// when handed its first chunk after N rounds (each collected, and checkpointed, by rank 0),
// dies (MCPT_MPI_FAULT=kill, the default: SIGKILL), stops (stop: SIGSTOP, a hung rank) or
// answers the next round with sums of another image size (bad-size).
struct Fault {
    int after_rounds = -1;
    std::string kind;
};

Fault injected_fault() {
    const char* rank = std::getenv("MCPT_MPI_FAULT_RANK");
    const char* after = std::getenv("MCPT_MPI_FAULT_AFTER_ROUNDS");
    const char* kind = std::getenv("MCPT_MPI_FAULT");
    Fault f;
    if (rank && after && std::atoi(rank) == g_job.rank) {
        f.after_rounds = std::atoi(after);
        f.kind = kind ? kind : "kill";
    }
    return f;
}

}  // namespace

const MpiJob& mpi_start(int& argc, char**& argv) {
    // Only under mpirun (Open MPI, or a PMI launcher such as Slurm's srun).
    if (!std::getenv("OMPI_COMM_WORLD_SIZE") && !std::getenv("PMI_SIZE") &&
        !std::getenv("PMIX_RANK"))
        return g_job;
    int provided = 0;
    MPI_Init_thread(&argc, &argv, MPI_THREAD_SERIALIZED, &provided);
    g_started = true;
    if (provided < MPI_THREAD_SERIALIZED) {
        MPI_Finalize();
        g_started = false;
        throw Error("this MPI library offers no MPI_THREAD_SERIALIZED: mcpt needs it");
    }
    MPI_Comm_rank(MPI_COMM_WORLD, &g_job.rank);
    MPI_Comm_size(MPI_COMM_WORLD, &g_job.size);
    MPI_Comm local;
    MPI_Comm_split_type(MPI_COMM_WORLD, MPI_COMM_TYPE_SHARED, g_job.rank, MPI_INFO_NULL, &local);
    MPI_Comm_rank(local, &g_job.local_rank);
    MPI_Comm_free(&local);
    return g_job;
}

void mpi_finish() {
    if (g_started) MPI_Finalize();
    g_started = false;
}

void mpi_abort(int code) {
    MPI_Abort(MPI_COMM_WORLD, code);
    std::exit(code);
}

std::vector<std::unique_ptr<Worker>> mpi_remote_workers(const Fingerprint& job_fingerprint,
                                                        const RankJob& job) {
    std::vector<std::unique_ptr<Worker>> workers;
    for (int rank = 1; rank < g_job.size; ++rank) {
        // Each rank says which device it opened and what job it was started for, or why it
        // could not (ranks compile their kernels first: ten times the floor for that).
        MPI_Status st;
        if (!wait_for(rank,
                      Clock::now() + std::chrono::duration_cast<Clock::duration>(
                                         std::chrono::duration<double>(10 * job.timeout_floor_s)),
                      st))
            throw Error(rank_name(rank) + " did not report its device within " +
                        std::to_string(int(10 * job.timeout_floor_s)) + " s: hung or stopped");
        if (st.MPI_TAG == kError) throw_rank_error(rank, st);
        if (st.MPI_TAG != kHello)
            throw Error(rank_name(rank) + " sent a message of tag " + std::to_string(st.MPI_TAG) +
                        " where its device and job were due");
        const std::string text = receive_text(rank, st);
        const size_t eol = text.find('\n');
        const std::string device = text.substr(0, eol);
        const Fingerprint theirs =
            decode_fingerprint(eol == std::string::npos ? "" : text.substr(eol + 1));
        // The same job: every key of rank 0's fingerprint but the device, both ways.
        const std::string key = fingerprint_difference(job_fingerprint, theirs, {"device"});
        if (!key.empty())
            throw Error(rank_name(rank) + " (" + device + ") was started for another job: " + key +
                        " " + fingerprint_value(theirs, key) +
                        " (rank 0: " + fingerprint_value(job_fingerprint, key) + ")" +
                        (key == "scene" ? "; the scene's hash covers its lighting (--env, "
                                          "--background)"
                                        : ""));
        workers.push_back(std::make_unique<RankWorker>(rank, device, job));
    }
    return workers;
}

void mpi_serve(Session& session) {
    try {
        session.commit();
    } catch (const std::exception& e) {
        send_error(e, false);
        return;
    }
    const std::string hello =
        session.device().label() + "\n" + encode_fingerprint(session.fingerprint());
    MPI_Send(hello.data(), int(std::min<size_t>(hello.size(), kMaxText)), MPI_BYTE, 0, kHello,
             MPI_COMM_WORLD);
    const Fault fault = injected_fault();
    bool bad_size = false;
    for (int rounds = 0;;) {
        MPI_Status st;
        MPI_Probe(0, MPI_ANY_TAG, MPI_COMM_WORLD, &st);
        if (st.MPI_TAG == kRound) {
            // The round's sums to rank 0.
            MPI_Recv(nullptr, 0, MPI_BYTE, 0, kRound, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
            ++rounds;
            RenderResult r;
            session.add_round_to(r);
            const ResultHeader h{r.first,
                                 r.spp,
                                 r.nonfinite_total,
                                 r.exact.empty() ? 0u : 1u,
                                 uint64_t(r.width) + (bad_size ? 1u : 0u),
                                 uint64_t(r.height),
                                 r.rays,
                                 r.seconds};
            MPI_Send(&h, sizeof h, MPI_BYTE, 0, kResult, MPI_COMM_WORLD);
            if (r.spp == 0) continue;
            if (!r.exact.empty()) {
                send_bytes(r.exact.data(), r.exact.size() * sizeof(ExactSum), 0, kResult);
            } else {
                send_bytes(r.sum.data(), r.sum.size() * sizeof(double), 0, kResult);
                send_bytes(r.sum_sq.data(), r.sum_sq.size() * sizeof(double), 0, kResult);
            }
            send_bytes(r.nonfinite.data(), r.nonfinite.size() * sizeof(double), 0, kResult);
            continue;
        }
        // Rank 0's chunks are checked too: two sample indices, in order (end 0: stop).
        uint64_t range[2] = {0, 0};
        if (st.MPI_TAG != kChunk || count_of(st) != int(sizeof range)) {
            send_error(Error("rank 0 sent a message of tag " + std::to_string(st.MPI_TAG) +
                             " where a chunk was due"),
                       false);
            return;
        }
        MPI_Recv(range, 2, MPI_UINT64_T, 0, kChunk, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
        if (range[1] == 0) return;
        if (fault.after_rounds >= 0 && rounds >= fault.after_rounds) {
            if (fault.kind == "stop")
                std::raise(SIGSTOP);
            else if (fault.kind == "bad-size")
                bad_size = true;
            else
                std::raise(SIGKILL);
        }
        try {
            if (range[0] >= range[1]) throw Error("rank 0 handed out an empty chunk");
            session.render_chunk(range[0], range[1]);
        } catch (const DeviceLost& e) {
            send_error(e, true);
            return;
        } catch (const std::exception& e) {
            send_error(e, false);
            return;
        }
        MPI_Send(nullptr, 0, MPI_BYTE, 0, kDone, MPI_COMM_WORLD);
    }
}

#endif

}  // namespace mcpt
