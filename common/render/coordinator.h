// One image on several devices: the samples of every pixel are split into chunks of sample
// indices [first, end), handed out to whichever device asks next and sized to its measured
// speed, so devices of different speed finish together. Each chunk comes back as sums of its
// own and is added in sample order; the image is always a whole prefix [0, spp) of samples.
// In reproducible mode the sums are exact (exact_sums.h): the image of N devices of one kind
// is the image of one, bit for bit, whatever N and the timing.
#pragma once
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <map>
#include <memory>
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
    // Renders samples [chunk.first, chunk.end) of every pixel into sums of their own
    // (RenderResult::first = chunk.first). Once `stop` is set it may return fewer (whole
    // groups when reproducible). Throws mcpt::Error (mcpt::DeviceLost) when it fails.
    virtual RenderResult render(const Chunk& chunk, const std::atomic<bool>& stop) = 0;
};

struct JobLimits {
    uint64_t end = 0;            // the sample index the job ends at; 0: no end
    double seconds = 0;          // hand out no chunk that would end after this; 0: no limit
    double target_error = 0;     // stop at this relative error (RenderResult); 0: none
    uint32_t granule = 1;        // chunks start and end at multiples of this (group_spp)
    double chunk_seconds = 0.5;  // a chunk's duration on the device that takes it
};

struct WorkerStats {
    std::string name;
    uint64_t chunks = 0;
    uint64_t samples = 0;  // samples per pixel rendered, in all chunks
    double seconds = 0;    // time in chunks
    double rate = 0;       // samples per pixel per second in its last chunk; 0: unknown
};

class Coordinator {
  public:
    // Adds to `total`, which holds samples [0, total.spp) already, or nothing. `rates` are
    // the workers' speeds from an earlier job (samples per pixel per second), if known.
    Coordinator(RenderResult& total, const JobLimits& limits, const std::vector<Worker*>& workers,
                const std::vector<double>& rates = {});

    // The next chunk for worker w, or none: the job is done, stopped or failed. Thread-safe.
    std::optional<Chunk> next(size_t w);
    // Worker w's sums of `chunk` (fewer samples if stopped), rendered in `seconds`.
    void done(size_t w, const Chunk& chunk, RenderResult sums, double seconds);
    // Worker w failed: the job stops; its chunk, and every later one, is not added.
    void failed(size_t w, const std::string& why, bool device_lost);
    // Stops handing out chunks; running ones end early (`stop`).
    void cancel();

    // Runs every worker in a thread of its own until no chunk is left, then returns. Throws
    // mcpt::Error (DeviceLost if the worker's device was lost) naming the failed worker; the
    // total keeps every sample before the failed chunk. `cancel`, if given, is polled.
    void run(const std::atomic<bool>* cancel = nullptr);

    bool target_reached() const { return target_reached_; }
    bool cancelled() const { return cancelled_; }
    const std::vector<WorkerStats>& stats() const { return stats_; }
    std::vector<double> rates() const;
    // Seconds spent adding chunks' sums (under the lock, in the threads of the workers).
    double reduce_seconds() const { return reduce_s_; }

  private:
    double elapsed() const;
    void reduce();  // adds the pending chunks that continue the total, in order
    RenderResult& total_;
    JobLimits lim_;
    std::vector<Worker*> workers_;
    std::vector<WorkerStats> stats_;
    std::chrono::steady_clock::time_point start_;
    std::mutex mutex_;
    std::condition_variable changed_;
    std::atomic<bool> stop_{false};
    uint64_t next_first_ = 0;                    // the first sample not handed out yet
    std::map<uint64_t, RenderResult> pending_;  // chunks done, waiting for an earlier one
    size_t running_ = 0;                         // workers with a chunk
    bool handed_any_ = false, target_reached_ = false, cancelled_ = false;
    std::string failure_;
    bool failure_lost_ = false;
    double reduce_s_ = 0;
};

}  // namespace mcpt
