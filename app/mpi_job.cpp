#include "app/mpi_job.h"

#include <csignal>
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
std::vector<std::unique_ptr<Worker>> mpi_remote_workers() {
    return {};
}
void mpi_serve(Session&) {}

#else

namespace {

// Messages between rank 0 and the others.
enum Tag : int {
    kHello = 1,   // rank -> 0: its device's name
    kChunk = 2,   // 0 -> rank: first, end (end 0: stop)
    kDone = 3,    // rank -> 0: the chunk is rendered
    kRound = 4,   // 0 -> rank: send the round's sums
    kResult = 5,  // rank -> 0: the round's sums (header, then arrays)
    kError = 6,   // rank -> 0: why it failed (first byte 1: its device was lost)
};

bool g_started = false;  // MPI_Init done

// MPI calls from several threads of rank 0 (MPI_THREAD_SERIALIZED): one at a time.
std::mutex g_mpi;

// Arrays in pieces below MPI's int count.
void send_bytes(const void* data, size_t bytes, int to, int tag) {
    const char* p = static_cast<const char*>(data);
    constexpr size_t kPiece = size_t(1) << 30;
    for (size_t at = 0; at < bytes; at += kPiece)
        MPI_Send(p + at, int(std::min(kPiece, bytes - at)), MPI_BYTE, to, tag, MPI_COMM_WORLD);
}
void recv_bytes(void* data, size_t bytes, int from, int tag) {
    char* p = static_cast<char*>(data);
    constexpr size_t kPiece = size_t(1) << 30;
    for (size_t at = 0; at < bytes; at += kPiece)
        MPI_Recv(p + at, int(std::min(kPiece, bytes - at)), MPI_BYTE, from, tag, MPI_COMM_WORLD,
                 MPI_STATUS_IGNORE);
}

struct ResultHeader {
    uint64_t first, spp, nonfinite_total, exact, width, height;
    double rays, seconds;
};

// Waits for a message from `rank` without holding the lock (other ranks' threads go on).
MPI_Status wait_for(int rank) {
    for (;;) {
        {
            std::lock_guard<std::mutex> lock(g_mpi);
            int flag = 0;
            MPI_Status st;
            MPI_Iprobe(rank, MPI_ANY_TAG, MPI_COMM_WORLD, &flag, &st);
            if (flag) return st;
        }
        std::this_thread::sleep_for(std::chrono::microseconds(500));
    }
}

class RankWorker : public Worker {
  public:
    RankWorker(int rank, std::string device) : rank_(rank), device_(std::move(device)) {}
    ~RankWorker() override {
        // The job is over: this rank may exit.
        if (stopped_) return;
        std::lock_guard<std::mutex> lock(g_mpi);
        const uint64_t stop[2] = {0, 0};
        MPI_Send(stop, 2, MPI_UINT64_T, rank_, kChunk, MPI_COMM_WORLD);
    }
    std::string name() const override { return device_ + " (rank " + std::to_string(rank_) + ")"; }
    std::string device_name() const override { return device_; }
    void render(const Chunk& chunk) override {
        {
            std::lock_guard<std::mutex> lock(g_mpi);
            const uint64_t range[2] = {chunk.first, chunk.end};
            MPI_Send(range, 2, MPI_UINT64_T, rank_, kChunk, MPI_COMM_WORLD);
        }
        const MPI_Status st = wait_for(rank_);
        std::lock_guard<std::mutex> lock(g_mpi);
        if (st.MPI_TAG == kError) {
            int n = 0;
            MPI_Get_count(&st, MPI_BYTE, &n);
            std::string why(size_t(std::max(n, 1)), '\0');
            MPI_Recv(why.data(), n, MPI_BYTE, rank_, kError, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
            stopped_ = true;  // it has left the job
            const bool lost = why[0] == 1;
            why.erase(0, 1);
            if (lost) throw DeviceLost(why);
            throw Error(why);
        }
        MPI_Recv(nullptr, 0, MPI_BYTE, rank_, kDone, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
    }
    void add_round_to(RenderResult& total) override {
        std::lock_guard<std::mutex> lock(g_mpi);
        MPI_Send(nullptr, 0, MPI_BYTE, rank_, kRound, MPI_COMM_WORLD);
        ResultHeader h{};
        MPI_Recv(&h, sizeof h, MPI_BYTE, rank_, kResult, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
        if (h.spp == 0) return;
        RenderResult r;
        r.width = int(h.width), r.height = int(h.height);
        r.first = h.first, r.spp = h.spp, r.nonfinite_total = h.nonfinite_total;
        r.rays = h.rays, r.seconds = h.seconds;
        const size_t n = size_t(h.width) * h.height;
        r.sum.resize(3 * n), r.sum_sq.resize(3 * n), r.nonfinite.resize(n);
        r.exact.resize(h.exact ? 6 * n : 0);
        if (h.exact) {
            recv_bytes(r.exact.data(), r.exact.size() * sizeof(ExactSum), rank_, kResult);
        } else {
            recv_bytes(r.sum.data(), r.sum.size() * sizeof(double), rank_, kResult);
            recv_bytes(r.sum_sq.data(), r.sum_sq.size() * sizeof(double), rank_, kResult);
        }
        recv_bytes(r.nonfinite.data(), r.nonfinite.size() * sizeof(double), rank_, kResult);
        accumulate_sums(total, r);
    }

  private:
    int rank_;
    std::string device_;
    bool stopped_ = false;
};

void send_error(const std::exception& e, bool lost) {
    const std::string why = std::string(1, lost ? '\1' : '\0') + e.what();
    MPI_Send(why.data(), int(why.size()), MPI_BYTE, 0, kError, MPI_COMM_WORLD);
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

std::vector<std::unique_ptr<Worker>> mpi_remote_workers() {
    std::vector<std::unique_ptr<Worker>> workers;
    for (int rank = 1; rank < g_job.size; ++rank) {
        // Each rank says which device it opened, or why it could not.
        MPI_Status st;
        MPI_Probe(rank, MPI_ANY_TAG, MPI_COMM_WORLD, &st);
        int n = 0;
        MPI_Get_count(&st, MPI_BYTE, &n);
        std::string text(size_t(std::max(n, 1)), '\0');
        MPI_Recv(text.data(), n, MPI_BYTE, rank, st.MPI_TAG, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
        text.resize(size_t(n));
        if (st.MPI_TAG == kError) {
            text.erase(0, 1);
            throw Error("rank " + std::to_string(rank) + ": " + text);
        }
        workers.push_back(std::make_unique<RankWorker>(rank, text));
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
    const std::string device = session.device().label();
    MPI_Send(device.data(), int(device.size()), MPI_BYTE, 0, kHello, MPI_COMM_WORLD);
    // Fault injection for tests: this rank dies (SIGKILL) when handed its first chunk after
    // N rounds (each collected, and checkpointed, by rank 0), whatever the machine's speed.
    const char* kill_rank = std::getenv("MCPT_MPI_KILL_RANK");
    const char* kill_after = std::getenv("MCPT_MPI_KILL_AFTER_ROUNDS");
    const int doomed_after =
        kill_rank && kill_after && std::atoi(kill_rank) == g_job.rank ? std::atoi(kill_after) : -1;
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
                                 uint64_t(r.width),
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
        uint64_t range[2];
        MPI_Recv(range, 2, MPI_UINT64_T, 0, kChunk, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
        if (range[1] == 0) return;
        if (doomed_after >= 0 && rounds >= doomed_after) std::raise(SIGKILL);
        try {
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
