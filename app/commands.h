// The mcpt subcommands: each one's arguments and the function that runs it, a thin client of
// the engine (common/render/session.h, common/analysis/*_job.h). Their options are parsed in
// app/main.cc, the one file that includes the command-line parser (CLI11, compiled once).
#pragma once
#include <string>
#include <vector>

#include "common/analysis/compare.h"
#include "common/render/device_registry.h"
#include "common/render/prepare.h"
#include "common/render/session.h"
#include "common/scene/scene_load.h"

namespace mcpt {

// Thrown by a command to end mcpt with this exit status (e.g. compare's verdict).
struct ExitStatus {
    int code;
};

// --tree's help, after what the option is for: the choices and what auto picks.
inline constexpr const char* kTreeChoicesHelp =
    "auto (per device: the wide BVH, or no tree where the cost model prefers; never the "
    "driver's tracing), sah, median, none, bvh (the wide BVH), rayquery (Vulkan devices with "
    "VK_KHR_ray_query: the driver traces), raypipeline (Vulkan devices with "
    "VK_KHR_ray_tracing_pipeline: the driver traces from a ray-generation shader)";

// Several devices: what each rendered of the session's image since its accumulation began,
// a line each ("  device K: NAME: C chunks, S spp (P%), R spp/s").
void print_device_shares(const Session& session);

// load_scene(arg) with its warnings printed to stderr.
Scene load_scene_argument(const std::string& arg);

// Light from the environment, for every command that renders: --env FILE.exr|.hdr
// (--env-rotate DEG, --env-scale S) or --background R,G,B.
struct LightingArgs {
    std::string env;
    float env_rotate = 0.f, env_scale = 1.f;
    std::string env_sampling = "compensated";
    std::string light_sampling = "auto";  // auto | power | tree | contribution
    // solid-angle | uniform | cosine | triangles | area
    std::string triangle_light_sampling = "solid-angle";
    std::vector<float> background;
};

// Sets how `scene` picks lights, from --light-sampling: tree, power, contribution, or auto
// (Scene::auto_light_by_contribution, else Scene::auto_light_tree). Throws mcpt::Error where
// contribution is asked of a scene that cannot have it.
void apply_light_sampling(Scene& scene, const LightingArgs& lighting);
// The environment the options ask for (none: Environment{}). Throws mcpt::Error.
Environment lighting_environment(const LightingArgs& a);

// mcpt render: one image of a scene.
struct RenderArgs {
    std::string scene = "cornell";
    std::string backend = "opencl";
    std::vector<std::string> devices;  // several: one image on all of them
    std::string limits;
    uint64_t spp = 0;
    double seconds = 0;
    int width = 256, height = 256;
    std::string output = "render.png";
    std::string tree = "auto";
    int depth = -1;
    int max_depth = -1;
    uint32_t seed = 0;
    bool fast_math = false;
    bool quiet = false;
    bool verbose = false;
    std::string specialize = "on";
    std::string sampler = "sobol";
    double target_error = 0;  // stop once the mean relative standard error is below this
    bool reproducible = false;
    bool adaptive = false;
    std::string checkpoint;          // resume from / save to this file
    double checkpoint_every = 30;    // seconds between checkpoints
    std::string part;                // "I/N": this run renders part I of N of the samples
    double chunk_seconds = 0.5;      // several devices: a chunk's duration
    double rank_timeout = 30;        // mpirun: the least time a rank is given to answer
    std::string reduction = "tree";  // mpirun: how a round's sums reach rank 0
    std::string display_server;      // "HOST:PORT": stream the image to tev
    LightingArgs lighting;
};
void run_render(const RenderArgs& args);

// mcpt tree: a tree's build and its cost, without rendering.
struct TreeArgs {
    std::string scene = "cornell";
    std::string tree = "sah";
    int depth = -1;
    int rays = 65536;
    int warps = 64;
};
void run_tree(const TreeArgs& args);

// mcpt compare: an A/B test of two sides on one scene.
struct CompareArgs {
    std::string scene = "cornell";
    std::string b_scene;  // B renders this file instead (another encoding of the same scene)
    LightingArgs lighting;
    std::string a = "opencl", b = "vulkan";
    int width = 64, height = 64;
    int batches = 32;
    uint64_t spp = 4;
    uint64_t same_seed_spp = 4;
    double same_seed_limit = kSameSeedDivergedLimit;
    int max_depth = -1;
    std::string tree = "auto";
    double alpha = 0.01;
    std::string output;
    std::string report;  // folder of the HTML report (index.html)
    float b_light_scale = 1.f;
    std::string b_defines;
    bool parallel = false;  // A and B at once, each in a thread of its own
};
void run_compare(const CompareArgs& args);

// mcpt converge: error against run time, per backend.
struct ConvergeArgs {
    std::string scene = "cornell";
    LightingArgs lighting;
    std::vector<std::string> backends{"opencl"};
    int width = 256, height = 256;
    double seconds = 10;
    uint64_t max_spp = 0;
    std::string checkpoints = "geometric";
    std::string reference = "auto";
    uint64_t reference_spp = 1024;
    std::vector<double> targets{0.10, 0.05};
    int max_depth = -1;
    std::string tree = "auto";
    std::string output = "converge";
    std::string report;  // folder of the HTML report (index.html)
    uint32_t seed = 1;
    std::vector<std::string> samplers{"sobol"};
    std::vector<std::string> sampling{"uniform"};
    std::vector<std::string> devices;  // --device repeated: each backend's run on all of them
    bool beside_one = false;           // and on its first device alone
};
void run_converge(const ConvergeArgs& args);

// mcpt bench: the thesis' tables (time per frame against triangles, trees, devices).
struct BenchArgs {
    bool quick = false;
    bool specialize = false;
    bool throughput = false;
    double seconds = 0;                 // --throughput: timed seconds per row (0: 5, quick 0.3)
    std::string tree = "auto";          // --throughput
    std::vector<int> device_counts;     // --throughput --devices 1,2,4
    std::vector<int> walk_steps;        // --throughput --walk-steps 0,4,6
    std::vector<std::string> backends;  // empty: every device found
    std::string models = "models";
    std::string output = "bench";
    int width = 0, height = 0;  // 0: 256 (quick: 64)
    uint64_t spp = 0;           // 0: 4 (quick: 2)
    int frames = 3;
    double max_frame_seconds = 10;
};
void run_bench(const BenchArgs& args);

// mcpt merge: the parts of a render (render --part I/N) added into one image.
struct MergeArgs {
    std::vector<std::string> parts;
    std::string output = "merged.exr";
    bool allow_missing = false;
};
void run_merge(const MergeArgs& args);

// mcpt view: the render live in a browser, one side or an A/B.
struct ViewArgs {
    std::string scene = "cornell";
    LightingArgs lighting;
    std::string backend = "opencl";
    std::vector<std::string> devices;  // one side: --device repeated, one image on all
    std::string a, b;                  // A/B: each side's device, or several (device_list)
    float b_light_scale = 1.f;
    int width = 512, height = 512;
    uint64_t spp = 0;    // each side stops there (0: renders until stopped)
    double seconds = 0;  // quit after this long (0: until Ctrl-C)
    uint32_t seed = 0;
    int max_depth = -1;
    std::string tree = "auto";
    std::string listen = "127.0.0.1";
    int port = 8017;
};
void run_view(const ViewArgs& args);

// mcpt devices: every device of every API, with the limits that matter.
void run_devices();

}  // namespace mcpt
