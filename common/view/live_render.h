// A render to watch while it converges: one session (or two, A and B, for an A/B run), each
// rendering on a thread of its own, publishing what a viewer shows (mcpt view): snapshots of
// the accumulation, the error against time and, for A and B, the maps of their difference.
// Steps of 0.5 s: two new images a second.
//
// The render threads never wait for a viewer: a snapshot is a copy of the sums made after a
// render step, and only when a viewer asked for one since the last; everything a viewer
// derives from it (images, maps, encodings) is computed on the viewer's threads.
// Thread safety: every public function may be called from any thread.
#pragma once
#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "common/analysis/compare.h"
#include "common/render/session.h"

namespace mcpt {

// One side's accumulation after a render step.
struct LiveSnapshot {
    RenderResult result;  // sums and counts (exact sums left out)
    uint64_t serial = 0;  // grows with every snapshot of the side, across resets
    double samples_per_second = 0, rays_per_second = 0;
    double relative_error = 0;  // RenderResult::relative_error(); HUGE_VAL while unknown
};

// A side's current speed: over its last second or so of render steps (wall time, pauses left
// out), not since the start, so that a viewer sees the rate now.
struct LiveRates {
    double samples_per_second = 0, rays_per_second = 0;
};

// A point of the error-against-time curve: after each render step.
struct ErrorPoint {
    double seconds = 0;  // render time since the start (or the last reset)
    uint64_t spp = 0;
    double relative_error = 0;
};

// A and B at one sample count (a milestone both reached): their difference, pixel by pixel.
struct LiveMaps {
    uint64_t spp = 0;
    DifferenceMaps maps;
};

// The sample counts at which A and B meet (both stop there, so their same-seed images can be
// compared): 4, 8, 12, ... then growing by a quarter, on multiples of 4. The first of that one
// sequence above `spp`.
uint64_t next_milestone(uint64_t spp);

class LiveRender {
  public:
    // Sessions with their scene and settings. Two: A and B, which should render the same seed
    // (their maps are same-seed comparisons). max_spp > 0: each side stops there and waits.
    explicit LiveRender(std::vector<std::unique_ptr<Session>> sides, uint64_t max_spp = 0);
    ~LiveRender();  // stops the threads
    LiveRender(const LiveRender&) = delete;
    LiveRender& operator=(const LiveRender&) = delete;

    void start();
    void stop();
    size_t sides() const { return sides_.size(); }
    // "opencl: Portable Computing Language ..." of a side.
    std::string label(size_t side) const;
    const Session& session(size_t side) const { return *sides_.at(side)->session; }

    // Paused sides finish their step and wait; reset drops every side's samples.
    void set_paused(bool paused);
    bool paused() const { return paused_.load(); }
    // Every side reached max_spp (and waits for a reset).
    bool done() const;
    void reset();

    // The side's latest snapshot (null before its first step). Asking for one makes the side
    // publish a new one after its next step.
    std::shared_ptr<const LiveSnapshot> snapshot(size_t side);
    // The latest snapshot without asking for a new one.
    std::shared_ptr<const LiveSnapshot> latest(size_t side) const;
    // snapshot(), waiting up to `timeout_s` for one newer than serial `since` (a viewer's long
    // poll: it asks once and gets the next image as soon as it exists). Null before the first.
    std::shared_ptr<const LiveSnapshot> next_snapshot(size_t side, uint64_t since,
                                                      double timeout_s);
    // The error curve: a point per render step, thinned evenly past 2048 points (the first
    // and the latest always kept).
    std::vector<ErrorPoint> error_series(size_t side) const;
    // A side on several devices: what each rendered so far, after the latest step (empty:
    // one device).
    std::vector<WorkerStats> device_stats(size_t side) const;
    // The side's current rates, updated after every step (zero before the first).
    LiveRates rates(size_t side) const;
    // A and B: the maps at the highest milestone both reached (null before), computed here on
    // the caller's thread the first time they are asked for.
    std::shared_ptr<const LiveMaps> maps();
    // Why a side stopped rendering ("A: ..."); empty while all render.
    std::string failure() const;

  private:
    struct Side {
        std::unique_ptr<Session> session;
        std::thread thread;
        std::atomic<bool> wanted{true};  // a viewer asked for a snapshot since the last
        std::shared_ptr<const LiveSnapshot> snapshot;
        std::vector<ErrorPoint> series;
        std::vector<WorkerStats> devices;
        uint64_t serial = 0;
        // The rate window: steps' wall time, samples and rays since it opened; the totals at
        // the last step; the rates of the last full window.
        double window_seconds = 0, window_samples = 0, window_rays = 0;
        double last_samples = 0, last_rays = 0;
        LiveRates rates;
        // Milestones reached and not yet met by the other side: mean and standard error.
        std::map<uint64_t, std::shared_ptr<const RenderResult>> milestones;
    };
    void run(size_t s);
    void publish(size_t s, uint64_t generation, double relative_error, double step_seconds);
    void reach_milestone(size_t s, uint64_t spp, uint64_t generation);
    std::vector<std::unique_ptr<Side>> sides_;
    uint64_t max_spp_;
    mutable std::mutex mutex_;           // everything below, and each Side's shared members
    std::condition_variable wake_;       // the render threads wait on it
    std::condition_variable published_;  // viewers waiting for a snapshot
    std::atomic<bool> paused_{false}, stopping_{false};
    uint64_t generation_ = 0;                     // grows with every reset
    std::shared_ptr<const RenderResult> met_[2];  // A and B at the last milestone both reached
    std::shared_ptr<const LiveMaps> maps_;
    std::string failure_;
    double b_slowdown_ = 1;  // MCPT_VIEW_SLOW_B (tests)
};

}  // namespace mcpt
