// Progressive rendering on any Backend: short dispatches sized to a time target, device sums
// flushed into double-precision host accumulators so nothing drifts over millions of samples.
#pragma once
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <functional>
#include <vector>

#include "common/io/host_memory.h"
#include "common/render/backend.h"
#include "common/render/exact_sums.h"

namespace mcpt {

struct RenderResult;

// Target duration of one dispatch: `requested` where positive, else the device's own.
// GPUs keep submissions short (drivers reset long ones, phones soonest; a dispatch is also how
// soon a render can stop). CPU devices (PoCL, lavapipe) pay a fixed cost per dispatch: 30 ms
// ran the Blender point-lamp scene 12-17% (PoCL) and 30% (lavapipe) slower than 120 ms
// (docs/benchmarks.md). A device held to the phone's limits keeps the GPU budget.
constexpr double kGpuDispatchMs = 30, kCpuDispatchMs = 120;
double dispatch_budget_ms(const DeviceInfo& device, double requested = 0);

struct RenderOptions {
    int width = 256, height = 256;
    uint64_t spp = 0;        // samples per pixel; 0: run for `seconds`
    double seconds = 0;      // time budget when spp == 0
    uint32_t max_depth = 8;  // bounces
    uint32_t rr_depth = 3;   // Russian roulette from this bounce on
    uint32_t seed = 0;
    float light_scale = 1.f;   // negative controls only
    double dispatch_ms = 0;    // target duration of one dispatch; 0: the device's own
    uint32_t flush_spp = 128;  // device float sums hold at most this many samples per pixel
    // > 0: reproducible: samples reach the double sums only in groups that end at multiples
    // of group_spp samples (1 when the sums are windowed), and the device adds each sample to
    // its float sums in sample order, so the image depends only on the seed and the sample
    // count, not on how passes and dispatches were timed. A flush() between group ends shows
    // the group so far on top of a copy of the sums (the image stays current; twice the host
    // memory). 0: every flush() moves the device sums into the double sums.
    uint32_t group_spp = 0;
    // Adaptive sampling: after kAdaptiveWarmupSpp samples everywhere, each pass gives pixels
    // samples in proportion to their estimated noise, unbiased (adaptive.h); spp is then the
    // mean over pixels, and RenderResult::samples holds each pixel's count. Not with group_spp.
    bool adaptive = false;
    // Negative control only: sigma from the pixel's own warm-up (adaptive.h: biased).
    bool adaptive_own_noise = false;
    // Optional early stop, asked after every flush; when set, every pass is flushed.
    std::function<bool(const RenderResult&)> stop_when;
};

struct RenderResult {
    int width = 0, height = 0;
    uint64_t spp = 0;    // samples per pixel taken (adaptive: the mean, rounded down)
    uint64_t first = 0;  // the first sample index they hold: [first, first + spp) of every pixel
    double seconds = 0;  // wall time of the dispatch loop
    std::vector<double> sum;        // 3 per pixel: sum of finite samples
    std::vector<double> sum_sq;     // 3 per pixel: sum of squared finite samples
    std::vector<double> nonfinite;  // per pixel: non-finite samples (counted, not added)
    std::vector<double> samples;    // per pixel: samples taken (adaptive); empty: spp each
    double rays = 0;                // rays traced
    uint64_t nonfinite_total = 0;
    // Reproducible: sum and sum_sq as exact fixed point (exact_sums.h), 6 per pixel; sum and
    // sum_sq are their values as doubles (materialize()). Empty otherwise.
    std::vector<ExactSum> exact;

    // Samples pixel i took, non-finite ones included.
    double pixel_samples(size_t i) const { return samples.empty() ? double(spp) : samples[i]; }

    // Mean radiance per pixel (3 floats), the image.
    std::vector<float> mean_image() const;
    // Standard error of the mean per pixel and channel (3 floats), from the sample variance.
    std::vector<float> std_error_image() const;
    double mean_radiance() const;  // over all pixels and channels
    // Mean standard error over pixels and channels relative to the mean radiance: the error
    // the image still carries. HUGE_VAL while unknown (fewer than 2 samples, or black).
    double relative_error() const;
    // sum and sum_sq from the exact sums.
    void materialize();
};

// Pixel i's mean and standard error of the mean in channel c (0 where unknown: no samples, or
// fewer than two): what the image, the error image and the relative error are made of.
struct ChannelStats {
    float mean = 0, std_error = 0;
};
inline ChannelStats channel_stats(const RenderResult& r, size_t i, int c) {
    const double count = r.pixel_samples(i) - r.nonfinite[i];
    if (count <= 0) return {};
    const double mean = r.sum[3 * i + c] / count;
    if (count < 2) return {float(mean), 0.f};
    // The sample variance / count: (E[x^2] - mean^2) / (count - 1).
    const double se2 = std::max(0.0, r.sum_sq[3 * i + c] / count - mean * mean) / (count - 1);
    return {float(mean), float(std::sqrt(se2))};
}

// Adds `part` (samples [part.first, part.first + part.spp)) to `to`, which must end where it
// begins (or be empty): exact sums exactly, otherwise in double. Throws mcpt::Error on a gap,
// another size, mixed exact and inexact sums, or exact sums out of range. Exact sums' doubles
// are brought up to date by to.materialize().
void add_sums(RenderResult& to, const RenderResult& part);
// Adds `part`'s sums and counts to `to` wherever its samples lie (to.first kept); an empty `to`
// takes part's. Throws mcpt::Error as add_sums() does, but for the placement.
void accumulate_sums(RenderResult& to, const RenderResult& part);
// Adds every part, as accumulate_sums() one after the other would, in one pass over the image.
void accumulate_sums(RenderResult& to, const std::vector<const RenderResult*>& parts);

// The render loop as a resumable object: passes of a few rounds each, device sums flushed into
// double precision every options.flush_spp samples. A round gives every pixel of a tile some
// samples; its dispatches each run at most `bounce budget` bounces per pixel and are repeated
// (paths carried across them on the device) until no pixel owes samples, so no dispatch
// outlasts options.dispatch_ms by much, whatever the path lengths. Tile size, samples per
// round and the bounce budget adapt to measured times. Sessions keep one across calls;
// render_loaded() runs one.
class ProgressiveRender {
  public:
    // The backend must hold the scene at options' size (Backend::load done).
    ProgressiveRender(Backend& backend, const GpuScene& scene, const Camera& camera,
                      const RenderOptions& options);
    // The target duration of one dispatch: the options', or the device's (dispatch_budget_ms).
    double dispatch_ms() const { return opt_.dispatch_ms; }
    // One pass: every pixel gets between 1 and max_spp more samples, as many as the dispatch
    // time target allows. Returns the samples per pixel added (not yet in result() until a
    // flush; pass() flushes by itself whenever the device sums reach flush_spp).
    uint32_t pass(uint64_t max_spp = UINT64_MAX);
    // Adds the device sums into result().
    void flush();
    // Seconds since a flush last added samples; HUGE_VAL before the first (exact sums on the
    // device: before the first whole group).
    double seconds_since_flush() const;
    // Forgets the samples not yet flushed (the device stopped: its sums are gone), so
    // result() holds exactly the samples flushed before (reproducible: before the last group
    // end).
    void discard_unflushed();
    // The sums as a checkpoint keeps them: everything flushed (reproducible: up to the last
    // group end, so that a resumed render adds the same groups). Flush first otherwise.
    const RenderResult& settled();
    // Continues from sums a checkpoint kept (their size must be the image's): the next sample
    // is saved.first + saved.spp.
    void restore(const RenderResult& saved);
    // Starts empty sums at sample index `first` (a multiple of group_spp when reproducible):
    // the samples of a chunk (coordinator.h), added elsewhere.
    void begin_at(uint64_t first);
    // Starts over from empty sums at sample index `first` with another seed and light scale
    // (a new independent render of the same scene), keeping the measured timings: a new loop
    // would start from small dispatches.
    void restart(uint32_t seed, float light_scale, uint64_t first);
    // Continues the sums with samples from index `first` on (another chunk; after whole groups
    // when reproducible): they then hold samples of several ranges, counted in spp.
    void continue_at(uint64_t first);
    // settled() without bringing exact sums' doubles up to date; after a flush().
    const RenderResult& settled_sums() const { return group_ > 0 ? settled_ : r_; }
    // Seconds the last pass took, and the longest and the median dispatch so far.
    double last_pass_seconds() const { return last_pass_s_; }
    double longest_dispatch_seconds() const { return longest_dispatch_s_; }
    uint64_t longest_dispatch_number() const { return longest_at_; }  // counted from 1
    double median_dispatch_seconds() const;
    uint64_t dispatches() const { return dispatch_s_.size(); }
    RenderResult& result() { return r_; }
    const RenderResult& result() const { return r_; }

  private:
    // A pass of adaptive sampling after the warm-up (adaptive.h).
    uint32_t adaptive_pass(uint64_t max_spp);
    // Rounds over tiles of `tile` pixels: `spp` samples each from sample index `first`, or
    // plan[i] samples for pixel i from its own count on; the sums of a window are read back
    // after each. Returns the seconds spent in dispatches.
    double run_tiles(uint32_t tile, uint32_t spp, uint32_t first,
                     const std::vector<uint32_t>* plan);
    // The work per dispatch (pixel-samples) from a pass's samples and its dispatch seconds.
    void retarget(double samples, double dispatch_s);
    // Pixels per round for `spp` samples each: about one dispatch's work, within the slots.
    uint32_t tile_for(uint32_t spp) const;
    // The device sums into device_sums_ (a window's are there already), then added to `to`.
    void read_device_sums();
    void add_device_sums(RenderResult& to) const;
    // The device sums to the host's: all of them, or (reproducible) a whole group's into the
    // exact settled sums, or into the device's exact sums where it keeps them (fold_group());
    // result()'s doubles are brought up to date by flush().
    void settle();
    // Reproducible, exact sums on the device: the group's float sums added to them there (no
    // read-back; fold_sums.h), and the device's exact sums read back and added to settled_.
    void fold_group();
    void sync_exact();
    Backend& backend_;
    RenderOptions opt_;
    gpu::GpuParams p_{};
    RenderResult r_;
    RenderResult settled_;  // reproducible: the sums up to the last group end (read back)
    // Reproducible, exact sums on the device: the groups since the last sync_exact() are
    // there (device_groups_), up to sample count device_spp_.
    bool exact_on_device_ = false, device_groups_ = false;
    bool synced_once_ = false;  // a group has reached the host (the first does at once)
    uint64_t device_spp_ = 0;
    std::vector<uint32_t> exact_words_;  // a chunk of them, read back
    void show_settled();  // result()'s sums = settled_'s (its sample count and time kept)
    bool stale_ = false;  // settled_'s doubles lag its exact sums
    uint64_t base_ = 0;   // the first sample index of the sums (begin_at())
    uint32_t group_ = 0;  // reproducible: samples per group (0: not reproducible)
    uint32_t npix_ = 0, unflushed_ = 0;
    double work_ = 0, last_pass_s_ = 0, longest_dispatch_s_ = 0;
    uint64_t longest_at_ = 0;
    uint32_t bounce_budget_ = 16;    // bounces per sample in one dispatch
    std::vector<float> dispatch_s_;  // every dispatch's wall time
    std::vector<float> device_sums_;
    uint32_t slots_ = 0;     // path-state slots: the largest tile
    bool windowed_ = false;  // the device holds one tile's sums at a time (gpu_scene.h)
    bool flushed_ = false;
    bool begun_empty_ = false;  // begin_at() zeroed the sums and no pass or restore came since
    std::chrono::steady_clock::time_point flushed_at_;
    std::vector<float> window_sums_;
    // Adaptive sampling: the sums of the warm-up's first half, sigma per pixel (adaptive.h),
    // this pass's plan and one tile's plan words.
    RenderResult half_;
    std::vector<double> sigma_;
    std::vector<uint32_t> plan_, plan_words_;
};

// Adaptive sampling starts once every pixel has this many samples.
constexpr uint32_t kAdaptiveWarmupSpp = 16;

// Host memory the accumulators of one pixel take: ProgressiveRender refuses an image that
// needs more than half of host_memory_available() (common/io/host_memory.h).
uint64_t host_bytes_per_pixel();

using ProgressFn = std::function<void(double fraction, const RenderResult& so_far)>;

// Loads the scene on the backend, then renders it.
RenderResult render(Backend& backend, const GpuScene& scene, const Camera& camera,
                    const RenderOptions& options, const ProgressFn& progress = nullptr);

// Renders on a backend that already holds the scene at options' size (load() done):
// for repeated renders with other seeds or light scales.
RenderResult render_loaded(Backend& backend, const GpuScene& scene, const Camera& camera,
                           const RenderOptions& options, const ProgressFn& progress = nullptr);

}  // namespace mcpt
