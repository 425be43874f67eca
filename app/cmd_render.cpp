// mcpt render: progressive rendering with a progress bar, throughput and per-pixel error.
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <memory>

#include "app/commands.h"
#include "common/error.h"
#include "common/image_io.h"
#include "common/render_loop.h"
#include "common/scene_features.h"
#include "opencl/cl_backend.h"
#if MCPT_WITH_VULKAN
#include "vulkan/vk_backend.h"
#endif

namespace mcpt {

namespace {

struct RenderArgs {
    std::string scene = "cornell";
    std::string backend = "opencl";
    std::string device;
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
    double target_error = 0;  // stop once the mean relative standard error is below this
};

std::unique_ptr<Backend> open_backend(const RenderArgs& a) {
    BackendOptions o;
    o.device = a.device;
    o.fast_math = a.fast_math;
    o.features = a.specialize == "on" ? 0u : FEATURE_ALL;
    if (a.backend == "opencl") return make_opencl_backend(o);
#if MCPT_WITH_VULKAN
    if (a.backend == "vulkan") return make_vulkan_backend(o);
    throw Error("unknown backend '" + a.backend + "' (available: opencl, vulkan)");
#else
    throw Error("unknown backend '" + a.backend + "' (available: opencl; built without Vulkan)");
#endif
}

void print_progress(double frac, const RenderResult& r) {
    const int width = 30;
    const int filled = int(std::round(frac * width));
    const double paths = double(r.spp) * r.width * r.height;
    std::fprintf(stderr, "\r[%s%s] %3d%%  %6.1f s  %llu spp  %.2f M paths/s ",
                 std::string(size_t(filled), '#').c_str(),
                 std::string(size_t(width - filled), ' ').c_str(), int(frac * 100), r.seconds,
                 (unsigned long long)r.spp, r.seconds > 0 ? paths / r.seconds * 1e-6 : 0.0);
    std::fflush(stderr);
}

void run_render(const RenderArgs& a) {
    // Scene, device, tree (auto: with the device's cost model), device layout.
    Scene scene = load_scene_argument(a.scene);
    std::unique_ptr<Backend> backend = open_backend(a);
    TreeOptions to = tree_options(a.tree, a.depth);
    to.auto_model = tree_cost_model(backend->device());
    const KdTree tree = build_kdtree(scene.triangles, to);
    const GpuScene gpu_scene = pack_scene(scene, tree);
    std::printf("scene: %s: %zu triangles, %zu spheres, %zu materials, %u lights\n",
                scene.name.empty() ? a.scene.c_str() : scene.name.c_str(),
                scene.triangles.size(), scene.spheres.size(), scene.materials.size(),
                gpu_scene.params.num_lights);
    if (a.verbose && !tree.auto_choice.empty()) std::printf("%s\n", tree.auto_choice.c_str());
    std::printf("tree: %s: %zu nodes, %zu leaves, depth %d, %.1f refs/leaf, %.2f ms, %zu bytes\n",
                a.tree == "auto" ? (tree.stats.nodes > 1 ? "auto (sah)" : "auto (none)")
                                 : a.tree.c_str(),
                tree.stats.nodes, tree.stats.leaves, tree.stats.max_depth,
                tree.stats.mean_leaf_size, tree.stats.build_seconds * 1e3, tree.stats.bytes);

    // Render.
    RenderOptions ro;
    ro.width = a.width, ro.height = a.height;
    ro.spp = a.spp;
    ro.seconds = a.seconds;
    if (ro.spp == 0 && ro.seconds <= 0 && a.target_error > 0) ro.seconds = HUGE_VAL;
    if (ro.spp == 0 && ro.seconds <= 0) ro.spp = 64;
    // --target-error: mean standard error / mean radiance, checked at every flush (>= 16 spp).
    double rel_error = HUGE_VAL;
    if (a.target_error > 0) {
        ro.stop_when = [&](const RenderResult& r) {
            const std::vector<float> e = r.std_error_image();
            double sum = 0;
            for (float v : e) sum += v;
            const double mean_l = r.mean_radiance();
            rel_error = mean_l > 0 && r.spp >= 2 ? sum / double(e.size()) / mean_l : HUGE_VAL;
            return r.spp >= 16 && rel_error < a.target_error;
        };
    }
    ro.max_depth = uint32_t(a.max_depth >= 0 ? a.max_depth
                                             : (scene.max_depth_hint > 0 ? scene.max_depth_hint : 8));
    ro.seed = a.seed;
    const bool bar = !a.quiet && isatty(2);
    auto progress = [&](double frac, const RenderResult& so_far) {
        // With a target error, progress is the fraction of the samples it needs.
        if (a.target_error > 0 && rel_error < HUGE_VAL)
            frac = std::max(frac, std::min(1.0, std::pow(a.target_error / rel_error, 2)));
        print_progress(frac, so_far);
    };
    const RenderResult r = render(*backend, gpu_scene, scene.camera, ro,
                                  bar ? ProgressFn(progress) : ProgressFn());
    if (bar) std::fprintf(stderr, "\n");

    // Throughput and the error the image still carries.
    const double pixels = double(r.width) * r.height;
    const double paths = double(r.spp) * pixels;
    std::printf("device: %s (kernel build %.2f s)\n", backend->description().c_str(),
                backend->compile_seconds());
    if (a.verbose) {
        std::printf("features used: %s\n", feature_names(gpu_scene.features).c_str());
        std::printf("compiled for: %s; left out: %s\n",
                    feature_names(backend->compiled_features()).c_str(),
                    features_left_out(backend->compiled_features()).c_str());
    }
    std::printf("rendered %dx%d, %llu spp, max depth %u in %.3f s: %.3f M samples/s, %.2f M rays/s\n",
                r.width, r.height, (unsigned long long)r.spp, ro.max_depth, r.seconds,
                paths / r.seconds * 1e-6, r.rays / r.seconds * 1e-6);
    const std::vector<float> err = r.std_error_image();
    double mean_err = 0, max_err = 0;
    for (float e : err) mean_err += e, max_err = std::max<double>(max_err, e);
    mean_err /= double(err.size());
    const double mean_l = r.mean_radiance();
    std::printf("standard error per pixel and channel (sample variance): mean %.4g, max %.4g; "
                "relative to mean radiance %.4g: %.2f%%\n",
                mean_err, max_err, mean_l, mean_l > 0 ? 100.0 * mean_err / mean_l : 0.0);
    if (a.target_error > 0) {
        const bool reached = mean_l > 0 && r.spp >= 16 && mean_err / mean_l < a.target_error;
        std::printf("target relative error %.2f%%: %s\n", 100 * a.target_error,
                    reached ? "reached" : "not reached (stopped by --time or --spp)");
    }
    if (r.nonfinite_total > 0) {
        std::printf("WARNING: %llu invalid samples (NaN/Inf, or paths a device loop limit cut "
                    "short) were counted and left out\n",
                    (unsigned long long)r.nonfinite_total);
    } else {
        std::printf("non-finite samples: 0\n");
    }
    write_image(a.output, r.width, r.height, r.mean_image());
    std::printf("wrote %s\n", a.output.c_str());
}

}  // namespace

void add_render_command(CLI::App& app) {
    auto args = std::make_shared<RenderArgs>();
    CLI::App* sub = app.add_subcommand("render", "Render a built-in scene or a glTF file");
    sub->add_option("scene", args->scene, "Built-in scene (cornell, furnace) or .gltf/.glb file")
        ->capture_default_str();
    sub->add_option("--backend", args->backend, "opencl or vulkan")->capture_default_str();
    sub->add_option("--device", args->device, "Device index or name substring (mcpt devices)");
    auto* spp = sub->add_option("--spp", args->spp, "Samples per pixel (default 64)");
    sub->add_option("--time", args->seconds, "Render for this many seconds instead")
        ->excludes(spp)
        ->check(CLI::PositiveNumber);
    sub->add_option("--target-error", args->target_error,
                    "Stop once mean standard error / mean radiance is below this (e.g. 0.05)")
        ->check(CLI::Range(1e-6, 1.0));
    sub->add_option("--width", args->width, "Image width")->check(CLI::Range(1, 16384))
        ->capture_default_str();
    sub->add_option("--height", args->height, "Image height")->check(CLI::Range(1, 16384))
        ->capture_default_str();
    sub->add_option("-o,--output", args->output, "Output image (.exr linear, .png sRGB)")
        ->capture_default_str();
    sub->add_option("--tree", args->tree,
                    "k-d tree: auto (SAH, or none where the cost model prefers), sah, median, none")
        ->check(CLI::IsMember({"auto", "sah", "median", "none"}))
        ->capture_default_str();
    sub->add_option("--depth", args->depth, "Tree depth limit (median: default 3)");
    sub->add_option("--max-depth", args->max_depth, "Bounces per path (default 8, or the scene's)")
        ->check(CLI::Range(0, 1000000));
    sub->add_option("--seed", args->seed, "Random seed")->capture_default_str();
    sub->add_flag("--fast-math", args->fast_math, "Compile with -cl-fast-relaxed-math");
    sub->add_option("--specialize", args->specialize,
                    "on: compile only the features the scene uses; off: the full kernel")
        ->check(CLI::IsMember({"on", "off"}))
        ->capture_default_str();
    sub->add_flag("-q,--quiet", args->quiet, "No progress bar");
    sub->add_flag("-v,--verbose", args->verbose, "Say what the build left out and why");
    sub->callback([args] { run_render(*args); });
}

}  // namespace mcpt
