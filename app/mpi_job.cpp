#include "app/mpi_job.h"

#include <chrono>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <mutex>
#include <thread>

#include "app/mpi_wire.h"
#include "common/error.h"
#include "common/render/device_registry.h"

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
void mpi_serve(Session&, bool) {}
std::vector<std::unique_ptr<BatchRenderer>> mpi_batch_renderers(const Fingerprint&,
                                                                const RankJob&) {
    return {};
}
void mpi_serve_batches(Session&) {}

#else

namespace {

using namespace wire;

bool g_started = false;  // MPI_Init done

Clock::duration seconds(double s) {
    return std::chrono::duration_cast<Clock::duration>(
        std::chrono::duration<double>(std::min(s, 1e9)));
}

// Rank 0 to `rank`: two numbers of `tag` (a chunk's range, a batch's seed and samples; 0, 0:
// stop).
void send_pair(int rank, int tag, uint64_t a, uint64_t b) {
    std::lock_guard<std::mutex> hold(lock());
    const uint64_t pair[2] = {a, b};
    MPI_Send(pair, 2, MPI_UINT64_T, rank, tag, MPI_COMM_WORLD);
}

// How long a rank may take for `samples` samples per pixel at its measured `rate`: ten times
// the expected time, never less than `floor`; before a first measurement (which may warm a
// device up) ten times the floor.
double allowed_seconds(double samples, double rate, double floor) {
    return rate > 0 ? std::max(floor, 10 * samples / rate) : 10 * floor;
}

// Ranks above 0: rank 0's probed message `st` as two numbers of `tag` (`what` names them);
// false, and rank 0 told why, when it is another message.
bool receive_pair(const MPI_Status& st, int tag, const char* what, uint64_t pair[2]) {
    if (st.MPI_TAG != tag || count_of(st) != int(2 * sizeof(uint64_t))) {
        send_error(Error("rank 0 sent a message of tag " + std::to_string(st.MPI_TAG) +
                         " where " + what + " was due"),
                   false);
        return false;
    }
    MPI_Recv(pair, 2, MPI_UINT64_T, 0, tag, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
    return true;
}

// Ranks above 0: runs `work`; a failure goes to rank 0 (a lost device as such) and gives false.
template <typename Work>
bool reporting_failure(const Work& work) {
    try {
        work();
        return true;
    } catch (const DeviceLost& e) {
        send_error(e, true);
    } catch (const std::exception& e) {
        send_error(e, false);
    }
    return false;
}

// The ranks of a job as rank 0 sees them: what each was handed this round, and the round's
// collection over the tree (wire::tree_children), once a round for all of them.
struct RankGroup {
    RankJob job;
    int size = 1;
    std::vector<uint64_t> handed;  // per rank, samples per pixel this round
    std::vector<std::string> devices;
    std::vector<RenderResult> received;  // per child in the tree, its arrays kept round to round
    std::vector<char> told;              // per rank: its round has ended (under lock())

    // Ends the round on `rank` (its sums start up the tree); once a round. Under lock().
    void end_round(int rank) {
        if (told[size_t(rank)]) return;
        MPI_Send(nullptr, 0, MPI_BYTE, rank, kRound, MPI_COMM_WORLD);
        told[size_t(rank)] = 1;
    }

    // Ends the round on every rank not told yet and adds their sums to `total`: log2(size)
    // messages, each the sums of a subtree of ranks, checked against what those ranks were
    // handed.
    void collect(RenderResult& total) {
        {
            std::lock_guard<std::mutex> hold(lock());
            for (int rank = 1; rank < size; ++rank) end_round(rank);
        }
        const SumsShape shape{job.width, job.height, job.exact};
        const size_t n = size_t(job.width) * size_t(job.height);
        const double bytes = double(n) * (job.exact ? 6 * sizeof(ExactSum) + 8 : 56);
        // The floor, and the arrays at 50 MB/s at least for each level of the tree.
        int levels = 0;
        while ((1 << levels) < size) ++levels;
        const double allowed = job.timeout_floor_s + levels * bytes / 50e6;
        const auto deadline = Clock::now() + seconds(allowed);
        const std::vector<int> children = tree_children(0, size, job.flat_reduction);
        received.resize(children.size());
        for (size_t c = 0; c < children.size(); ++c) {
            const int child = children[c];
            const int end = tree_end(child, size, job.flat_reduction);
            uint64_t spp = 0;
            for (int r = child; r < end; ++r) spp += handed[size_t(r)];
            const std::string who = end - child == 1
                                        ? rank_name(child) + " (" + devices[size_t(child)] + ")"
                                        : "ranks " + std::to_string(child) + "-" +
                                              std::to_string(end - 1) + " (added up by rank " +
                                              std::to_string(child) + ")";
            RenderResult& part = received[c];
            if (!receive_sums(child, shape, spp, deadline, who, part)) {
                char text[160];
                std::snprintf(text, sizeof text,
                              " did not deliver the round's sums within %.1f s: hung or stopped",
                              allowed);
                throw Error(who + text);
            }
            if (part.spp > 0) accumulate_sums(total, part);
        }
        std::fill(handed.begin(), handed.end(), 0);
        std::lock_guard<std::mutex> hold(lock());
        std::fill(told.begin(), told.end(), 0);
    }
};

class RankWorker : public Worker {
  public:
    RankWorker(int rank, std::shared_ptr<RankGroup> group)
        : rank_(rank), device_(group->devices[size_t(rank)]), group_(std::move(group)) {}
    ~RankWorker() override {
        // The job is over: this rank may exit.
        if (!stopped_) send_pair(rank_, kChunk, 0, 0);
    }
    std::string name() const override { return device_ + " (" + rank_name(rank_) + ")"; }
    std::string device_name() const override { return device_; }
    void render(const Chunk& chunk) override {
        send_pair(rank_, kChunk, chunk.first, chunk.end);
        // A deadline from this rank's measured speed.
        const double samples = double(chunk.end - chunk.first);
        const double expected = rate_ > 0 ? samples / rate_ : 0;
        const double allowed = allowed_seconds(samples, rate_, group_->job.timeout_floor_s);
        const auto start = Clock::now();
        MPI_Status st;
        if (!wait_for(rank_, start + seconds(allowed), st)) {
            stopped_ = true;
            char text[200], why[80] = "its first chunk: no speed measured yet";
            if (rate_ > 0)
                std::snprintf(why, sizeof why, "expected %.2f s at its measured speed", expected);
            std::snprintf(text, sizeof text,
                          "did not deliver samples %llu-%llu within %.1f s (%s): hung or stopped",
                          (unsigned long long)chunk.first, (unsigned long long)chunk.end, allowed,
                          why);
            throw Error(text);
        }
        std::lock_guard<std::mutex> hold(lock());
        if (st.MPI_TAG == kError) {
            stopped_ = true;  // it has left the job
            throw_rank_error(rank_, st);
        }
        if (st.MPI_TAG != kDone || count_of(st) != 0) {
            stopped_ = true;
            throw Error("sent a message of tag " + std::to_string(st.MPI_TAG) + " and " +
                        std::to_string(count_of(st)) + " bytes where the end of a chunk was due");
        }
        MPI_Recv(nullptr, 0, MPI_BYTE, rank_, kDone, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
        const double took = std::chrono::duration<double>(Clock::now() - start).count();
        if (took > 0) rate_ = samples / took;
        group_->handed[size_t(rank_)] += chunk.end - chunk.first;
    }
    // No chunk is left for this rank this round: it reads its sums back and adds its
    // children's while the other devices finish theirs.
    void finish_round() override {
        if (stopped_) return;
        std::lock_guard<std::mutex> hold(lock());
        group_->end_round(rank_);
    }
    // Rank 1's worker collects the round for every rank (the tree); the others add nothing.
    void add_round_to(RenderResult& total) override {
        if (rank_ != 1) return;
        try {
            group_->collect(total);
        } catch (const std::exception&) {
            stopped_ = true;
            throw;
        }
    }

  private:
    int rank_;
    std::string device_;
    std::shared_ptr<RankGroup> group_;
    bool stopped_ = false;
    double rate_ = 0;  // samples per pixel per second in its last chunk; 0: unknown
};

// Fault injection for tests (MCPT_MPI_FAULT_RANK, MCPT_MPI_FAULT_AFTER_ROUNDS): this rank,
// when handed its first chunk after N rounds (each collected, and checkpointed, by rank 0),
// dies (MCPT_MPI_FAULT=kill, the default: SIGKILL), stops (stop: SIGSTOP, a hung rank) or
// answers the next round with sums of another image size (bad-size; compare: its batches
// after N with means of another size) or without its children's in the tree (drop-children).
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

namespace {

// Rank 0: each other rank's greeting, in rank order: which device it opened and that it was
// started for this job, or why it could not. The devices, rank 0's first.
std::vector<std::string> receive_hellos(const Fingerprint& job_fingerprint, const RankJob& job) {
    std::vector<std::string> devices{"rank 0"};
    for (int rank = 1; rank < g_job.size; ++rank) {
        // (Ranks compile their kernels first: ten times the floor for that.)
        MPI_Status st;
        if (!wait_for(rank, Clock::now() + seconds(10 * job.timeout_floor_s), st))
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
        Fingerprint ours = job_fingerprint;
        ours.emplace_back("reduction", job.flat_reduction ? "flat" : "tree");
        const std::string key = fingerprint_difference(ours, theirs, {"device"});
        if (!key.empty())
            throw Error(rank_name(rank) + " (" + device + ") was started for another job: " + key +
                        " " + fingerprint_value(theirs, key) +
                        " (rank 0: " + fingerprint_value(ours, key) + ")" +
                        (key == "scene" ? "; the scene's hash covers its lighting (--env, "
                                          "--background)"
                                        : ""));
        devices.push_back(device);
    }
    return devices;
}

// Ranks above 0: commits `session` and greets rank 0 with its device and job; false (rank 0
// told why) when the commit fails.
bool send_hello(Session& session, bool flat_reduction) {
    try {
        session.commit();
    } catch (const std::exception& e) {
        send_error(e, false);
        return false;
    }
    Fingerprint job = session.fingerprint();
    job.emplace_back("reduction", flat_reduction ? "flat" : "tree");
    const std::string hello = session.device().label() + "\n" + encode_fingerprint(job);
    MPI_Send(hello.data(), int(std::min<size_t>(hello.size(), kMaxText)), MPI_BYTE, 0, kHello,
             MPI_COMM_WORLD);
    return true;
}

// A rank that renders compare's batches, seen from rank 0.
class RankBatchRenderer : public BatchRenderer {
  public:
    RankBatchRenderer(int rank, std::string device, const RankJob& job)
        : rank_(rank), device_(std::move(device)), job_(job) {}
    ~RankBatchRenderer() override {
        if (!stopped_) send_pair(rank_, kBatch, 0, 0);
    }
    std::string name() const override { return device_ + " (" + rank_name(rank_) + ")"; }
    BatchMean render(uint32_t seed, uint64_t spp) override {
        send_pair(rank_, kBatch, seed, spp);
        // A chunk's deadline (RankWorker).
        const double allowed = allowed_seconds(double(spp), rate_, job_.timeout_floor_s);
        const auto start = Clock::now();
        BatchMean out;
        try {
            if (!receive_batch_mean(rank_, job_.width, job_.height, spp,
                                    start + seconds(allowed), name(), out)) {
                char text[160];
                std::snprintf(text, sizeof text,
                              " did not deliver a batch of %llu spp within %.1f s: hung or stopped",
                              (unsigned long long)spp, allowed);
                throw Error(name() + text);
            }
        } catch (...) {
            stopped_ = true;
            throw;
        }
        const double took = std::chrono::duration<double>(Clock::now() - start).count();
        if (took > 0) rate_ = double(spp) / took;
        return out;
    }

  private:
    int rank_;
    std::string device_;
    RankJob job_;
    bool stopped_ = false;
    double rate_ = 0;  // samples per pixel per second in its last batch; 0: unknown
};

}  // namespace

std::vector<std::unique_ptr<Worker>> mpi_remote_workers(const Fingerprint& job_fingerprint,
                                                        const RankJob& job) {
    auto group = std::make_shared<RankGroup>();
    group->job = job, group->size = g_job.size;
    group->handed.assign(size_t(g_job.size), 0);
    group->told.assign(size_t(g_job.size), 0);
    group->devices = receive_hellos(job_fingerprint, job);
    std::vector<std::unique_ptr<Worker>> workers;
    for (int rank = 1; rank < g_job.size; ++rank)
        workers.push_back(std::make_unique<RankWorker>(rank, group));
    return workers;
}

std::vector<std::unique_ptr<BatchRenderer>> mpi_batch_renderers(
    const Fingerprint& job_fingerprint, const RankJob& job) {
    const std::vector<std::string> devices = receive_hellos(job_fingerprint, job);
    std::vector<std::unique_ptr<BatchRenderer>> renderers;
    for (int rank = 1; rank < g_job.size; ++rank)
        renderers.push_back(std::make_unique<RankBatchRenderer>(rank, devices[size_t(rank)], job));
    return renderers;
}

void mpi_serve_batches(Session& session) {
    if (!send_hello(session, false)) return;
    // Fault injection (MCPT_MPI_FAULT=bad-size): after N batches, means of another size.
    const Fault fault = injected_fault();
    for (int batches = 0;; ++batches) {
        // Two numbers from rank 0: a seed and a sample count (0: stop).
        MPI_Status st;
        MPI_Probe(0, MPI_ANY_TAG, MPI_COMM_WORLD, &st);
        uint64_t batch[2] = {0, 0};
        if (!receive_pair(st, kBatch, "a batch", batch) || batch[1] == 0) return;
        const bool bad_size =
            fault.kind == "bad-size" && fault.after_rounds >= 0 && batches >= fault.after_rounds;
        if (!reporting_failure([&] {
                if (batch[0] > UINT32_MAX) throw Error("rank 0 sent a seed out of range");
                session.settings().seed = uint32_t(batch[0]);
                session.reset();
                RenderGoal goal;
                goal.spp = batch[1];
                render_until(session, goal);
                send_batch_mean(batch_mean(session.result()), bad_size);
            }))
            return;
    }
}

void mpi_serve(Session& session, bool flat_reduction) {
    if (!send_hello(session, flat_reduction)) return;
    const Fault fault = injected_fault();
    bool bad_size = false, drop_children = false;
    // A round's sums, and its children's: their arrays kept from round to round.
    RenderResult mine;
    const std::vector<int> children = tree_children(g_job.rank, g_job.size, flat_reduction);
    std::vector<RenderResult> received(children.size());
    for (int rounds = 0;;) {
        MPI_Status st;
        MPI_Probe(0, MPI_ANY_TAG, MPI_COMM_WORLD, &st);
        if (st.MPI_TAG == kRound) {
            // The round ends: this rank's sums, and those of its children in the tree (each
            // checked), to its parent.
            MPI_Recv(nullptr, 0, MPI_BYTE, 0, kRound, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
            ++rounds;
            // Emptied with its memory kept: the first sums added are copied into it.
            mine.sum.clear(), mine.sum_sq.clear(), mine.nonfinite.clear(), mine.exact.clear();
            mine.samples.clear();
            mine.width = mine.height = 0;
            mine.spp = mine.first = mine.nonfinite_total = 0, mine.rays = mine.seconds = 0;
            session.add_round_to(mine);
            const SumsShape shape{session.settings().width, session.settings().height,
                                  session.settings().reproducible};
            for (size_t c = 0; c < children.size(); ++c) {
                RenderResult& part = received[c];
                receive_sums(children[c], shape, kAnySpp, Clock::time_point::max(),
                             rank_name(children[c]), part);
                // (Fault drop-children: a subtree that loses its children's sums.)
                if (part.spp > 0 && !drop_children) accumulate_sums(mine, part);
            }
            send_sums(mine, tree_parent(g_job.rank, flat_reduction), bad_size);
            continue;
        }
        // Rank 0's chunks are checked too: two sample indices, in order (end 0: stop).
        uint64_t range[2] = {0, 0};
        if (!receive_pair(st, kChunk, "a chunk", range) || range[1] == 0) return;
        if (fault.after_rounds >= 0 && rounds >= fault.after_rounds) {
            if (fault.kind == "stop")
                std::raise(SIGSTOP);
            else if (fault.kind == "bad-size")
                bad_size = true;
            else if (fault.kind == "drop-children")
                drop_children = true;
            else
                std::raise(SIGKILL);
        }
        if (!reporting_failure([&] {
                if (range[0] >= range[1]) throw Error("rank 0 handed out an empty chunk");
                session.render_chunk(range[0], range[1]);
            }))
            return;
        MPI_Send(nullptr, 0, MPI_BYTE, 0, kDone, MPI_COMM_WORLD);
    }
}

#endif

}  // namespace mcpt
