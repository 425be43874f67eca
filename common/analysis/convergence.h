// Error against run time: progressive renders (one sample sequence), their error
// against a reference (exact, or a cached high-sample render whose own noise is subtracted),
// log-log convergence fits, a bias flag, and time-to-error. Shared by `mcpt converge` and the
// tests, so both judge a render by the same code.
#pragma once
#include <atomic>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "common/render/render_loop.h"
#include "common/render/session.h"
#include "common/scene/scene.h"

namespace mcpt {

// The image an estimate converges to, with the variance of its own estimate (0 if exact).
struct Reference {
    int width = 0, height = 0;
    std::vector<double> mean;      // 3 per pixel
    std::vector<double> variance;  // 3 per pixel: squared standard error of `mean`
    uint64_t spp = 0;              // samples behind `mean`; 0: exact
    std::string source;            // one line, for the output
    bool exact() const { return spp == 0; }
    double mean_value() const;      // over pixels and channels
    double noise_variance() const;  // mean of `variance`
};

// A constant image (an exact solution).
Reference constant_reference(int width, int height, double value, const std::string& source);
// A render as a reference: its mean and squared standard error per pixel and channel.
Reference reference_from_render(const RenderResult& render, const std::string& source);

// Le / (1 - rho) if the scene is a white furnace (named "furnace", every material diffuse
// with one grey albedo and one grey emission); false otherwise.
bool exact_furnace_radiance(const Scene& scene, double& value);

// The cache directory for references: $XDG_CACHE_HOME/mcpt, else ~/.cache/mcpt.
std::string reference_cache_dir();
// 64-bit FNV-1a of the rendered content: geometry, materials, lights, camera at this size,
// bounce limits, and `extra` (e.g. the kernel source), never the tree.
uint64_t reference_key(const GpuScene& scene, const Camera& camera, int width, int height,
                       uint32_t max_depth, uint32_t rr_depth, const std::string& extra);
// Reads a reference written by save_reference(); false if absent or not matching the size.
bool load_reference(const std::string& path, int width, int height, Reference& out);
// Writes atomically (temporary file, then rename); throws mcpt::Error on failure.
void save_reference(const std::string& path, const Reference& ref);

struct ErrorMetrics {
    double mse = 0;                // mean (image - ref)^2 over pixels and channels, less the
                                   // reference's own variance (never below 0)
    double rmse = 0;               // sqrt(mse)
    double rel_mse = 0;            // mean (image - ref)^2 / (ref^2 + 1e-2), less the same
                                   // weighted reference variance
    double rel_rmse = 0;           // rmse / mean reference radiance
    double mean_signed_error = 0;  // mean (image - ref): the bias once the noise is gone
    double reference_noise = 0;    // RMS standard error of the reference (0 if exact)
};

ErrorMetrics measure_error(const RenderResult& render, const Reference& ref);

// Adds an independent batch (another seed) into `total`: sums, counts, rays and time.
void accumulate(RenderResult& total, const RenderResult& batch);

// How many pixels the MSE effectively averages over: (sum v)^2 / sum v^2 of the per-pixel
// sample variances v (channel means). All of them for a uniform image, a few when fireflies
// dominate; it sets the expected spread of the fitted slopes.
double effective_pixels(const RenderResult& render);

struct Checkpoint {
    double seconds = 0;  // render time so far (dispatch loops; error measurement excluded)
    uint64_t spp = 0;
    ErrorMetrics error;
};

enum class Schedule {
    SppDoubling,   // checkpoints at 1, 2, 4, 8, ... spp (the last one cut at the time budget)
    TimeDoubling,  // checkpoints at seconds / 2^(n-1), ..., seconds / 2, seconds
};

struct ProgressiveOptions {
    Schedule schedule = Schedule::SppDoubling;
    uint64_t max_spp = 0;  // stop once this many samples per pixel are taken (0: no limit)
    double seconds = 0;    // stop once this much render time is spent (0: no limit)
    int time_checkpoints = 8;
    uint32_t seed_base = 1;  // the seed of the one sample sequence
    // Set: the render ends once it is true, at a last checkpoint of what was rendered.
    const std::atomic<bool>* cancel = nullptr;
};

// Renders progressively through `session` (its scene and settings: size, bounces, tree,
// sampler, adaptive sampling; the seed is opt.seed_base), from zero, one sample sequence
// continued to each checkpoint (doubling sample counts or times), measuring the error of the
// image so far at each. `total` (optional) receives the final accumulation; `on_checkpoint`
// (optional) sees each checkpoint.
std::vector<Checkpoint> render_progressive(
    Session& session, const ProgressiveOptions& opt, const Reference& ref,
    RenderResult* total = nullptr,
    const std::function<void(const Checkpoint&)>& on_checkpoint = nullptr);

struct LogLogFit {
    double slope = 0, intercept = 0;  // log y = intercept + slope * log x
    size_t points = 0;
    double at(double x) const;
};
// Least squares over the points with x > 0 and y > 0.
LogLogFit fit_loglog(const std::vector<double>& x, const std::vector<double>& y);

struct ConvergenceReport {
    LogLogFit time_fit;         // RMSE against seconds
    LogLogFit spp_fit;          // RMSE against samples per pixel
    double slope_sigma = 0;     // expected spread of spp_fit.slope for an unbiased estimator
    double local_slope = 0;     // RMSE against spp over the last three checkpoints
    double noise_floor = 0;     // 3 x the reference's RMS noise
    bool biased = false;        // the last checkpoints flatten above the noise floor
    double estimated_bias = 0;  // mean signed error at the last checkpoint
    double relative_bias = 0;   // estimated_bias / mean reference radiance
    std::string verdict() const;
};

// Fits and the bias flag: biased when the local slope is above -0.25 (and more than four
// expected spreads above -0.5) while the RMSE is above the noise floor. `pixels`: the
// effective pixel count (effective_pixels()), which sets slope_sigma.
ConvergenceReport analyze_convergence(const std::vector<Checkpoint>& checkpoints,
                                      double reference_mean, double pixels);

struct TimeToError {
    bool reached = false;       // a checkpoint got there (interpolated in log-log)
    bool extrapolated = false;  // not reached: projected along the local slope
    bool before_first = false;  // already below target at the first checkpoint
    double seconds = 0;         // 0 when neither reached nor projectable (flat or biased)
    std::string text() const;   // "3.21 s", "~41.0 s (extrapolated)", "<= 0.05 s", "never"
};

// Time for the relative RMSE (rmse / mean reference) to fall to `target`.
TimeToError time_to_error(const std::vector<Checkpoint>& checkpoints, double target,
                          const ConvergenceReport& report);

}  // namespace mcpt
