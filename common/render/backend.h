// What the render loop needs from a GPU API: compile for a scene, upload it, run one
// dispatch, read the accumulation buffer back. opencl/ and vulkan/ implement it.
#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include "common/render/gpu_scene.h"

namespace mcpt {

// What a device allows a scene's buffers, filled by the OpenCL and Vulkan device lists and
// checked by check_device_limits() (device_limits.h) before anything is allocated.
struct MemoryLimits {
    uint64_t max_buffer_bytes = 0;      // largest buffer a kernel may bind; 0: unknown
    std::string max_buffer_name;        // the API's name for it, for messages
    std::string max_buffer_note;        // why it is lower than the device says, if it is
    uint64_t max_allocation_bytes = 0;  // largest allocation when a separate limit; 0: none
    std::string max_allocation_name;
    uint64_t device_memory_bytes = 0;  // memory buffers come from; 0: unknown
};

struct DeviceInfo {
    std::string backend;   // "opencl" | "vulkan"
    int index = 0;         // position in that backend's device list
    std::string name;      // device name
    std::string platform;  // OpenCL platform / Vulkan driver
    std::string type;      // "gpu" | "cpu" | "other"
    std::vector<std::pair<std::string, std::string>> limits;  // name, value (for display)
    bool phone_limits = false;   // held to the phone's limits (Vulkan limits=phone)
    bool ray_queries = false;    // the driver traces rays for us (Vulkan VK_KHR_ray_query)
    bool ray_pipelines = false;  // the same through VK_KHR_ray_tracing_pipeline
    MemoryLimits memory;
    // "opencl: NVIDIA H100": the device in messages and checkpoints.
    std::string label() const { return backend + ": " + name; }
};

struct BackendOptions {
    std::string device;         // "" (best), an index, or a name substring
    bool fast_math = false;     // -cl-fast-relaxed-math / equivalent
    std::string extra_defines;  // extra -D options for test variants (e.g. "-DMCPT_COUNTERS")
    // Tests: how the environment is reached (MCPT_ENV_STRATEGY, common/gpu/integrator.h; 0 =
    // MIS, what renders use). Both APIs: OpenCL defines it, Vulkan specializes it.
    uint32_t env_strategy = 0;
    // Device features to compile for (FEATURE_* bits): 0 = the scene's own (the default),
    // FEATURE_ALL = the full kernel; another mask only in tests' negative controls.
    uint32_t features = 0;
    // Non-zero: a build no driver or pipeline cache has seen (cold compile timings).
    uint32_t compile_nonce = 0;
    // Vulkan limits profile: "device" or "phone" (the Vulkan 1.1 minimums); "" =
    // $MCPT_VULKAN_LIMITS, else device. OpenCL takes only "" or "device".
    std::string limits;
    // Fault injection for tests: the device reports itself lost at this dispatch (counted from
    // 1; 0 = never); open_device() takes $MCPT_LOSE_DEVICE_AFTER when 0.
    uint32_t lose_device_after = 0;
    // Fault injection for tests of the driver's tracing (--tree rayquery, raypipeline):
    // "drop:N" leaves triangle N out of the acceleration structure, "shrink" makes every
    // sphere's box half its size, "shift" moves every sphere's box by 1.5 radii along +z.
    std::string accel_fault;
    // Tests: a largest buffer smaller than the device's (0 = the device's), so that large
    // images take the windowed accumulation (gpu_scene.h) on any device.
    uint64_t max_buffer_bytes = 0;
    // Vulkan: how the shader reads the tree, triangles and shading data: "texel" (texel buffers),
    // "storage" (storage buffers), or "" = $MCPT_VULKAN_SCENE_READS, else texel buffers on CPU
    // devices (llvmpipe gathers texels, reads storage buffers lane by lane) and storage buffers
    // on GPUs. Texel reads fall back to storage where the scene exceeds maxTexelBufferElements.
    std::string scene_reads;
};

// The MCPT_FEATURES value a backend compiles `scene` with: the feature bits, and the compile
// nonce above them (ignored by the device code, but part of every cache key).
uint32_t compile_features(const BackendOptions& options, const GpuScene& scene);
// Measurements: where $MCPT_COMPILE_LOG names a file, each kernel or pipeline build appends a
// line to it, "<api>\t<seconds>\t<settings>" (what a test run compiles, and what it costs).
void log_compile(const char* api, double seconds, const std::string& settings);
// Node steps and triangles per k-d traversal iteration (KD_NODE_STEPS, KD_TRI_STEPS:
// common/gpu/traverse.h) for this device; $MCPT_KD_NODE_STEPS and $MCPT_KD_TRI_STEPS (1-32)
// override them, for measurements (builds with the steps' loops: OpenCL, and Vulkan's
// module for GPUs, which lavapipe runs with BackendOptions::scene_reads = "storage"); and
// whether an iteration overlaps a node step with a triangle test (KD_OVERLAP; every build but
// OpenCL's for CPU devices, which loops over each leaf), $MCPT_KD_OVERLAP (0 or 1).
struct KdSteps {
    uint32_t nodes = 1, triangles = 1;
    uint32_t overlap = 1;
};
KdSteps kd_steps(const DeviceInfo& device);

// How many places the kernel traces rays from (MCPT_TRACE_SITES, integrator.h: step_path()):
// 1, every ray from one traversal call, for NVIDIA's Vulkan driver on scenes with textures
// (FEATURE_TEXTURES), whose two inlined traversals beside the texture code overflowed its
// instruction cache, or with the k-d tree (FEATURE_KDTREE: +4 to +29% there), or through the
// ray-tracing pipeline (`ray_pipeline`: each traceRayEXT site keeps the path's live state
// across a call into the driver's traversal; one site 1.8x to 3.1x faster on an H100); else
// 2, the shadow ray traced where it is cast (docs/traversal.md).
// 1 also wherever the BVH is walked (walk_steps). $MCPT_TRACE_SITES (1 or 2) overrides.
// Images are the same either way on PoCL and lavapipe; NVIDIA's compilers round the two
// programs differently (both APIs, docs/benchmarks.md).
uint32_t trace_sites(const DeviceInfo& device, uint32_t features, bool ray_pipeline = false,
                     uint32_t tree_depth = 0);

// Node steps a ray's BVH walk takes before the lanes whose rays ended shade
// (MCPT_WALK_STEPS, integrator.h: step_slot_walk; 0: every ray walked to its end where it is
// traced). Nonzero only for scenes with the BVH (FEATURE_BVH), through our own traversal, and
// then with one trace site (trace_sites): 4 on NVIDIA's GPUs for a BVH of depth 6 or more
// (`tree_depth`: GpuScene::stack_size - 1), where waiting for the warp's longest ray costs
// more than the walk's bookkeeping. $MCPT_WALK_STEPS (0-32) overrides.
uint32_t walk_steps(const DeviceInfo& device, uint32_t features, bool driver_traced = false,
                    uint32_t tree_depth = 0);

// The register cap NVIDIA's OpenCL compiles a kernel with (-cl-nv-maxrregcount; 0: none) for
// its features and walk (walk_steps): left alone the compiler gives the kernel 109-157
// registers, so few warps fit an SM that loads wait uncovered. 128 for a walked BVH, 96 for a
// BVH walked whole, 56 for a BVH with textures and for the k-d tree and no tree (measured on
// an H100: docs/traversal.md, "The register cap by kernel"). $MCPT_NV_MAXRREGCOUNT (0, or 16
// to 255) overrides.
uint32_t nvidia_register_cap(uint32_t features, uint32_t walk);

class Backend {
  public:
    virtual ~Backend() = default;
    // "opencl: NVIDIA H100 (NVIDIA CUDA)".
    virtual std::string description() const = 0;
    virtual const DeviceInfo& device() const = 0;
    // Compiles the program for this scene (stack size), uploads its arrays and allocates the
    // accumulation buffer for width*height pixels, with room for exact sums when exact_sums
    // asks and they fit (accum_layout_for(), device_limits.h). Throws mcpt::Error on device
    // limits.
    virtual void load(const GpuScene& scene, int width, int height, bool exact_sums) = 0;
    // What load() allocated.
    virtual const AccumLayout& accum_shape() const = 0;
    // Runs one dispatch and waits for it; returns non-zero while some of its pixels still owe
    // samples of the round (their paths continue in the next dispatch, round_start = 0).
    // Throws mcpt::DeviceLost when the device stops (lost, or out of resources executing).
    virtual uint32_t dispatch(const gpu::GpuParams& params) = 0;
    // The sample plan of the first words.size() / PLAN_WORDS_PER_SLOT path-state slots
    // (shared_types.h), which rounds with GpuParams.sample_plan set follow.
    virtual void write_plan(const std::vector<uint32_t>& words) = 0;
    // The accumulation sums, ACCUM_VEC4_PER_PIXEL * 4 floats per pixel, of the first `pixels`
    // pixels the buffer holds (0: all; a window's tile may fill only part of it).
    virtual void read_accum(std::vector<float>& out, uint32_t pixels) = 0;
    // The exact sums (EXACT_VEC4_PER_PIXEL * 4 words per pixel, shared_types.h) of pixels
    // [first, first + count); only when accum_shape().exact_pixels covers them.
    virtual void read_exact(std::vector<uint32_t>& out, uint32_t first, uint32_t count) = 0;
    // Seconds spent compiling in load().
    virtual double compile_seconds() const = 0;
    // Device time spent in dispatches so far (OpenCL profiling events, Vulkan timestamps);
    // 0 where the device cannot time itself.
    virtual double device_seconds() const = 0;
    // Most bounces one dispatch may run per pixel: CPU Vulkan drivers end the loops of an
    // invocation after a fixed number of iterations (llvmpipe: 65,535 over all loops), so
    // they get a budget far below that; longer paths continue in the next dispatch.
    virtual uint32_t max_bounces_per_dispatch() const = 0;
    // The FEATURE_* bits the loaded program was compiled with.
    virtual uint32_t compiled_features() const = 0;
    // What the backend works within: "4 storage buffers per stage (device allows 4),
    // workgroup 64" (the buffers bound and the workgroup size).
    virtual std::string layout() const = 0;
    // What the loaded program was compiled with, as the compiler got it: OpenCL's build
    // options; Vulkan's specialization constants ("KD_NODE_STEPS=3 ..."). Empty before load().
    virtual std::string build_settings() const = 0;
    // What the device built for the loaded scene itself (the driver's acceleration
    // structures: --tree rayquery, raypipeline): seconds and bytes kept; zeros where nothing.
    struct DeviceBuild {
        double seconds = 0;
        uint64_t bytes = 0;
    };
    virtual DeviceBuild device_build() const { return {}; }
};

}  // namespace mcpt
