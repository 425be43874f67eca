// Do two renderers produce the same image? Statistical agreement from independent batches
// (per-pixel Welch t-tests on batch means with Sidak and Benjamini-Hochberg corrections,
// plus global tests for a small uniform bias), and same-seed agreement (identical random
// streams: what differs is float rounding and compiler behaviour).
#pragma once
#include <atomic>
#include <functional>
#include <future>
#include <memory>
#include <string>
#include <vector>

#include "common/render/render_loop.h"
#include "common/render/session.h"

namespace mcpt {

// Per-pixel batch means (mean of r, g, b) from `batches` independent renders.
struct BatchSet {
    int width = 0, height = 0, batches = 0;
    uint64_t spp_per_batch = 0;
    std::vector<double> mean, var;  // per pixel, over the batch means
    uint64_t nonfinite = 0;
    double seconds = 0, rays = 0;  // totals over all batches
    // Several devices: the batches each rendered (sessions, then remote, then joining ones).
    std::vector<int> per_device;
};

struct BatchOptions {
    int batches = 32;
    uint64_t spp_per_batch = 4;
    uint32_t seed_base = 1;  // batch b uses seed seed_base + b
    // Set: no batch starts once it is true (those in flight finish); the set then holds the
    // batches done (`batches` says how many; no means below two).
    const std::atomic<bool>* cancel = nullptr;
    // Set: called after each batch, on the thread that rendered it (a progress count).
    std::function<void()> on_batch;
};

// One batch as the test needs it: per pixel the mean of r, g and b; its totals.
struct BatchMean {
    int width = 0, height = 0;
    uint64_t spp = 0, nonfinite = 0;
    double seconds = 0, rays = 0;
    std::vector<double> mean;
};
BatchMean batch_mean(const RenderResult& render);

// Batch means from independent renders of one size (two at least).
BatchSet batch_means(const std::vector<BatchMean>& batches);
BatchSet batch_means(const std::vector<RenderResult>& renders);

// Loads the scene once, then renders the batches with independent seeds.
BatchSet render_batches(Backend& backend, const GpuScene& scene, const Camera& camera,
                        RenderOptions options, const BatchOptions& batch);
// The same through a session (its scene and settings; the seeds are set here), each batch
// rendered from zero by render_until(), the loop of `mcpt render`.
BatchSet render_batches(Session& session, const BatchOptions& batch);
// A device elsewhere (an MPI rank) that renders whole batches for render_batches().
class BatchRenderer {
  public:
    virtual ~BatchRenderer() = default;
    virtual std::string name() const = 0;
    // The batch of `seed` at `spp` samples per pixel. Throws mcpt::Error.
    virtual BatchMean render(uint32_t seed, uint64_t spp) = 0;
};

// A device still opening (made and committed on a thread of its own): it joins the batches
// when ready, if any are left; one ready after the last batch was handed out renders none.
struct JoiningSession {
    std::string name;                                    // as the user named it, for messages
    std::shared_future<std::shared_ptr<Session>> ready;  // get() throws what opening threw
};

// The same batches on several sessions at once (each a device: batches are independent
// renders, handed to whichever session is free); batch b is the render of seed_base + b
// whichever renders it. `seconds` is the wall time of them all. `first`, if set, runs on the
// first session before it takes a batch (the others start on batches meanwhile).
// `remote` render batches too, each in a thread of its own, and so do `joining` once ready.
BatchSet render_batches(const std::vector<Session*>& sessions, const BatchOptions& batch,
                        const std::function<void(Session&)>& first = {},
                        const std::vector<BatchRenderer*>& remote = {},
                        const std::vector<JoiningSession>& joining = {});

struct Agreement {
    size_t pixels_tested = 0;  // pixels with variance or differing means
    double min_p = 1, sidak_level = 0;
    // The least p-value a pixel can get: that of a permutation test of the two sides' batches
    // (2 / C(nA + nB, nA)), the finest any test that assumes nothing of their distribution
    // can resolve. Welch's test, which assumes normal batch means, is floored at it.
    double p_floor = 0;
    int batches_needed = 0;  // a side, for p_floor to reach below sidak_level
    size_t sidak_rejections = 0;
    size_t bh_discoveries = 0;  // pixels flagged at false discovery rate alpha
    double mean_z_score = 0;    // sum of signed z / sqrt(m): ~N(0,1) if unbiased
    double chi2_score = 0;      // Wilson-Hilferty normal score of sum z^2 vs chi2(m)
    double global_z_limit = 0;  // |mean_z_score| and chi2_score must stay below this
    // Smallest uniform relative bias the mean-z test detects with kDetectionPower (90%) power
    // (its shift of the mean z must reach the limit plus the 90% normal quantile), in pixels
    // whose error is sampling noise; pixels without noise (lights seen directly) only add
    // power. Calibrated by CompareCalibration.* (tests/compare_test.cpp).
    double detectable_bias = 0;
    double mean_relative_diff = 0;  // (mean B - mean A) / mean A over all pixels
    bool agree = true;
    std::vector<float> p_image;   // per-pixel p-values
    std::vector<float> z_image;   // per-pixel signed z (B - A)
    std::string verdict() const;  // one line
};

// The power with which Agreement::detectable_bias is detected.
constexpr double kDetectionPower = 0.9;

// Relative difference of per-pixel means that counts as float rounding, not bias: well
// above what two compilers' ulps add up to over a path, far below what the tests detect.
constexpr double kFloatRoundingTolerance = 2e-5;

// Tests whether A and B have equal per-pixel means, family-wise level alpha; each pixel's
// difference carries kFloatRoundingTolerance of its mean as rounding uncertainty.
Agreement test_agreement(const BatchSet& a, const BatchSet& b, double alpha = 0.01);

// The fraction of pixels whose same-seed renders may diverge without a defect: float
// rounding sends a few paths another way (glass edges, Russian roulette at the threshold).
// Measured on unbiased pairs (64x64, 4 spp, and 256x256 at 16 and 64 spp; cornell, spheres,
// furnace, dragons): at most 0.146% (PoCL vs NVIDIA Vulkan, spheres), 0.081% between NVIDIA's
// OpenCL and Vulkan (871k dragon, 64 spp), 0.049% PoCL vs lavapipe; a light 0.2% brighter in
// one side diverges 63-100% of the pixels. The limit sits 7x above the first, 60x below the
// second.
constexpr double kSameSeedDivergedLimit = 0.01;

struct SameSeedDiff {
    size_t pixels = 0, diverged = 0;  // diverged: relative difference > tolerance
    double max_abs_diff = 0, tolerance = 1e-3;
    double fraction_diverged() const { return pixels ? double(diverged) / double(pixels) : 0; }
    // Same images up to rounding: few enough pixels diverged. Catches any change of the
    // integrand larger than the tolerance (0.1%) over much of the image, however noisy.
    bool agree(double limit = kSameSeedDivergedLimit) const { return fraction_diverged() <= limit; }
};

// Per-pixel comparison of two renders made with the same seed and sample count.
SameSeedDiff same_seed_diff(const RenderResult& a, const RenderResult& b, double tolerance = 1e-3);

// Per-pixel maps of two renders of one size (the viewer, compare and converge reports).
struct DifferenceMaps {
    int width = 0, height = 0;
    // (B - A) / sqrt(seA^2 + seB^2 + rounding^2) of the channel means, each side's standard
    // error from its sample variance (the mean of its channels' errors: an upper bound), the
    // rounding kFloatRoundingTolerance of the larger mean. Of renders with the same seed (A and
    // B share their samples) a conservative score: unbiased sides stay near 0, a bias shows
    // wherever it exceeds the noise, first where there is none (lights seen directly).
    std::vector<float> z;
    // max over channels of |B - A| / max(|A|, |B|, 1e-3): what same_seed_diff() counts.
    std::vector<float> relative;
    SameSeedDiff same_seed;  // relative > tolerance, counted
};
DifferenceMaps difference_maps(const RenderResult& a, const RenderResult& b,
                               double tolerance = 1e-3);

}  // namespace mcpt
