// The A/B test as a library call: one scene rendered by two sides (each one device or several,
// with its own options), independent batches on both for the statistical test and one
// same-seed render each for the rounding test, timed side by side. `mcpt compare`, the C API
// (mcpt_compare_*) and the Java Compare class are its clients.
#pragma once
#include <atomic>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "common/analysis/compare.h"
#include "common/render/session.h"
#include "common/scene/scene.h"

namespace mcpt {

// One side of the A/B: its devices and what it renders differently from the other.
struct CompareSideSpec {
    // Device specs, one per device rendering this side together (device_list() of
    // "opencl:0,opencl:1,limits=phone"); the first renders the same-seed image.
    std::vector<std::string> devices{"opencl"};
    std::string tree;                    // trace mode; "": CompareSpec::tree (a tree= option wins)
    float light_scale = 1.f;             // emitters scaled (the negative control: 1.02)
    std::string extra_defines;           // OpenCL defines (negative controls)
    std::shared_ptr<const Scene> scene;  // null: CompareSpec::scene (B: another encoding)
};

struct CompareSpec {
    std::shared_ptr<const Scene> scene;  // lit, its lights chosen (apply_light_sampling)
    CompareSideSpec sides[2];
    int width = 64, height = 64;
    int batches = 32;  // independent batches per side (two at least)
    uint64_t spp = 4;  // samples per pixel per batch
    uint64_t same_seed_spp = 4;
    double same_seed_limit = kSameSeedDivergedLimit;
    int max_depth = -1;  // -1: the scene's default
    std::string tree = "auto";
    double alpha = 0.01;    // family-wise false alarm rate
    bool parallel = false;  // both sides at once, each on its devices
    // Set: called after each batch of side 0 (A) or 1 (B), from the thread that rendered it.
    std::function<void(int side)> on_batch;
    // Devices elsewhere (MPI ranks) that render a side's batches too; none when unset.
    std::function<std::vector<std::unique_ptr<BatchRenderer>>(Session& first, int side)> remote;
};

// What one side did: its devices, its batches and same-seed image, and where its time went.
struct CompareSideResult {
    std::string first_device;  // its description
    std::string description;   // the first device's, "+N more" with several
    size_t devices = 1;
    std::string tree;      // the trace mode it rendered with
    int batches_done = 0;  // fewer than asked after a cancel
    BatchSet batches;      // valid when batches_done >= 2
    bool same_seed_done = false;
    RenderResult same_seed;
    double compile_seconds = 0;
    double device_seconds = 0;  // of the batches; 0 if unknown (several devices)
    double open_s = 0, batches_s = 0, same_seed_s = 0;  // wall time of its steps
    double samples_per_second() const;                  // of the batches
    double rays_per_second() const;
    double device_ns_per_sample() const;  // 0 if unknown
    double host_overhead() const;         // fraction of the batch time outside the kernel
};

struct CompareResult {
    int width = 0, height = 0;
    uint32_t max_depth = 0;
    // The plan it ran (CompareSpec's), for reports.
    int batches = 0;
    uint64_t spp = 0, same_seed_spp = 0;
    double same_seed_limit = 0, alpha = 0;
    bool parallel = false;
    CompareSideResult sides[2];
    bool cancelled = false;
    bool has_agreement = false;  // both sides rendered two batches at least
    Agreement agreement;
    bool has_same_seed = false;  // both sides rendered their same-seed image
    DifferenceMaps maps;
    bool same_seed_agrees = false;
    double tests_s = 0, total_s = 0;
    // Both tests ran and agree (a cancelled job with a test missing does not agree).
    bool agree() const {
        return has_agreement && has_same_seed && agreement.agree && same_seed_agrees;
    }
    double speed_ratio() const;  // B's samples per second over A's
};

// Runs an A/B test. Thread-safe cancel(): the batches in flight finish, no more start, and the
// result holds what was done. Throws mcpt::Error ("A: ..." / "B: ..." for a side's failure).
class CompareJob {
  public:
    explicit CompareJob(CompareSpec spec);
    CompareResult run();
    void cancel() { cancel_.store(true); }
    bool cancelled() const { return cancel_.load(); }

  private:
    CompareSpec spec_;
    std::atomic<bool> cancel_{false};
};

// The side spec of a command-line side: "opencl:0,opencl:1,limits=phone,tree=bvh".
CompareSideSpec compare_side(const std::string& side);

}  // namespace mcpt
