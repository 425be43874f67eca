// One image on several devices: the samples of every pixel are split into chunks of sample
// indices [first, end), handed out to whichever device asks next and sized to its measured
// speed, so devices of different speed finish together. A device adds its chunks to sums of
// its own; at the end of a round, when every chunk handed out is done, the devices' sums are
// added to the image, which so always holds a whole prefix [0, spp) of samples. Host work and
// transfers are once per device and round, not per chunk. In reproducible mode the sums are
// exact (exact_sums.h): the image of N devices of one kind is the image of one, bit for bit,
// whatever N and the timing.
#pragma once
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "common/render/render_loop.h"

namespace mcpt {

struct Chunk {
    uint64_t first = 0, end = 0;  // sample indices, of every pixel
};

// One device that renders chunks: a session in this process, an MPI rank.
class Worker {
  public:
    virtual ~Worker() = default;
    // "opencl: NVIDIA H100 (rank 2)", for messages and statistics.
    virtual std::string name() const = 0;
    // The device alone, "opencl: NVIDIA H100": what a reproducible image depends on.
    virtual std::string device_name() const { return name(); }
    // Renders samples [chunk.first, chunk.end) of every pixel into the round's sums. Throws
    // mcpt::Error (mcpt::DeviceLost) when it fails.
    virtual void render(const Chunk& chunk) = 0;
    // Its last chunk of the round is done: the sums may move to the host now, while other
    // devices still render (called on the worker's own thread; add_round_to() follows).
    virtual void finish_round() {}
    // Adds the round's sums (every chunk since the last call; samples counted, not placed) to
    // `total`, and starts a new round.
    virtual void add_round_to(RenderResult& total) = 0;
    // The round's sums when this process holds them (after finish_round()), for the
    // coordinator to add with the other workers' in one pass over the image; it then calls
    // start_round() instead of add_round_to(). nullptr: add_round_to() adds them.
    virtual const RenderResult* round_sums() { return nullptr; }
    virtual void start_round() {}
};

struct JobLimits {
    uint64_t end = 0;            // the sample index the job ends at; 0: no end
    double seconds = 0;          // hand out no chunk that would end after this; 0: no limit
    uint32_t granule = 1;        // chunks start and end at multiples of this (group_spp)
    double chunk_seconds = 0.5;  // a chunk's duration on the device that takes it
    // With an end: the rest is shared by no more devices than get this long a share each (a
    // device that joins a round adds its sums at the end: a tiny share costs more than it
    // saves; an unmeasured device counts at its peers' speed). 0: shared by all.
    double min_share_seconds = 0;
};

// A chunk shorter than this measures a worker's speed from below (its fixed cost weighs).
constexpr double kShortChunkSeconds = 0.02;

struct WorkerStats {
    std::string name;
    uint64_t chunks = 0;
    uint64_t samples = 0;       // samples per pixel rendered, in all chunks
    double seconds = 0;         // time in chunks
    double finish_seconds = 0;  // time reading the rounds' sums back (Worker::finish_round)
    // Samples per pixel per second in its last chunk (a short one: the fastest since); 0:
    // unknown.
    double rate = 0;
};

// One round of a job: chunks handed out until the limits, then the sums collected.
class Coordinator {
  public:
    // Adds to `total`, which holds samples [total.first, total.first + total.spp) already (or
    // nothing). `rates` are the workers' speeds from an earlier round, if known.
    Coordinator(RenderResult& total, const JobLimits& limits, const std::vector<Worker*>& workers,
                const std::vector<double>& rates = {});

    // The next chunk for worker w, or none: the round is done, stopped or failed. Thread-safe.
    std::optional<Chunk> next(size_t w);
    // Worker w rendered `chunk` in `seconds`.
    void done(size_t w, const Chunk& chunk, double seconds);
    // Worker w failed: no more chunks; the round adds nothing.
    void failed(size_t w, const std::string& why, bool device_lost);

    // Runs every worker in a thread of its own until no chunk is left, then adds their sums to
    // the total. Throws mcpt::Error (DeviceLost if a worker's device was lost) naming the failed
    // worker; the total is then as before the round. A set `cancel` ends the round early (the
    // chunks running finish).
    void run(const std::atomic<bool>* cancel = nullptr);

    bool cancelled() const { return cancelled_; }
    // The round ended at its time limit (not at its end sample).
    bool out_of_time() const { return out_of_time_; }
    const std::vector<WorkerStats>& stats() const { return stats_; }
    std::vector<double> rates() const;
    // Seconds spent adding the devices' sums to the total (and receiving them).
    double reduce_seconds() const { return reduce_s_; }

  private:
    double elapsed() const;
    // The measured workers' mean speed (samples per pixel per second); 0: none measured.
    double mean_rate() const;
    // Worker w's part of the `left` samples to hand out, asked at `now`: the workers free
    // before a common end (w now, the others when their chunks should end) share them by
    // speed so that all end together; the last to be free (unmeasured ones last among equals)
    // sit out while their part would last less than min_share_seconds. 0: w sits out (the
    // others, measured, take the rest). An equal split while no worker is measured.
    double share_of_rest(size_t w, double left, double now) const;
    RenderResult& total_;
    JobLimits lim_;
    std::vector<Worker*> workers_;
    std::vector<WorkerStats> stats_;
    std::vector<double> busy_until_;  // per worker: when its chunk should end (s since start)
    std::chrono::steady_clock::time_point start_;
    std::mutex mutex_;
    std::condition_variable changed_;
    bool stop_ = false;
    uint64_t next_first_ = 0;  // the first sample not handed out yet
    bool handed_any_ = false, cancelled_ = false, out_of_time_ = false;
    std::string failure_;
    bool failure_lost_ = false;
    double reduce_s_ = 0;
};

}  // namespace mcpt
