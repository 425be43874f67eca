// mcpt: Monte Carlo path tracer with a k-d tree, on OpenCL (and Vulkan). The command line:
// every subcommand's options, parsed by CLI11 (the one file that includes it: its header costs
// seconds of compile time per file), each then run by its app/cmd_*.cpp.
#include <CLI/CLI.hpp>
#include <iostream>
#include <memory>
#include <new>

#include "app/commands.h"
#include "app/mpi_job.h"
#include "common/accel/kdtree.h"

namespace mcpt {
namespace {

void add_lighting_options(CLI::App* sub, LightingArgs& a) {
    auto* env = sub->add_option("--env", a.env,
                                "Environment map lighting the scene (equirectangular, linear "
                                ".exr or .hdr; +Y up)");
    sub->add_option("--env-rotate", a.env_rotate, "Turn the environment about +Y (degrees)")
        ->check(CLI::Range(-1e6, 1e6));
    sub->add_option("--env-scale", a.env_scale, "Scale the environment's radiance")
        ->check(CLI::Range(0.0, 1e30));
    sub->add_option("--env-sampling", a.env_sampling,
                    "Next-event estimation of the environment: compensated (texels by their "
                    "luminance above the map's mean; BSDF sampling takes the rest) or luminance")
        ->check(CLI::IsMember({"compensated", "luminance"}))
        ->capture_default_str();
    sub->add_option("--light-sampling", a.light_sampling,
                    "How next-event estimation picks a light: power (every light by its power), "
                    "tree (local lights by their importance at the shading point), contribution "
                    "(scenes lit by 1 to 8 lamps only: each lamp by its unshadowed contribution, "
                    "the BSDF included) or auto (contribution where possible from 2 lamps, else "
                    "the tree from 2 local lights with a lamp or from 32, else power)")
        ->check(CLI::IsMember({"auto", "power", "tree", "contribution"}))
        ->capture_default_str();
    sub->add_option("--triangle-light-sampling", a.triangle_light_sampling,
                    "How next-event estimation samples an emissive triangle: solid-angle "
                    "(over the solid angle it subtends, where that is stable, else by area; the "
                    "two halves of a rectangle as one; warped toward the receiver's cosine "
                    "where the light spans 0.2 sr or more), or, to measure against, uniform "
                    "(never warped), cosine (warped wherever sampled by solid angle), "
                    "triangles (each half on its own) or area (uniform over its area)")
        ->check(CLI::IsMember({"solid-angle", "uniform", "cosine", "triangles", "area"}))
        ->capture_default_str();
    sub->add_option("--background", a.background,
                    "Constant background radiance R,G,B lighting the scene (default: black)")
        ->delimiter(',')
        ->expected(3)
        ->excludes(env);
}

void add_devices_command(CLI::App& app) {
    CLI::App* sub = app.add_subcommand("devices", "List backends and devices with their limits");
    sub->callback(run_devices);
}

void add_bench_command(CLI::App& app) {
    auto a = std::make_shared<BenchArgs>();
    CLI::App* sub = app.add_subcommand("bench", "The thesis' tables: models x trees x devices");
    sub->add_flag("--quick", a->quick, "64x64, 2 spp, small scenes only");
    sub->add_flag("--specialize", a->specialize,
                  "Full kernel vs builds for each scene's features (and --tree auto), with "
                  "cold and cached compile times");
    sub->add_flag("--throughput", a->throughput,
                  "Long renders (1024^2, 5 s after a warm-up) per scene and backend: rays/s, "
                  "Vulkan/OpenCL, work and bytes per ray");
    sub->add_option("--time", a->seconds, "--throughput: timed seconds per row (default 5)")
        ->check(CLI::PositiveNumber);
    sub->add_option("--tree", a->tree,
                    std::string("--throughput: trace modes separated by commas (rows for "
                                "each): ") +
                        kTreeChoicesHelp)
        ->check([](const std::string& v) {
            std::stringstream list(v);
            const std::vector<std::string> names = tree_kind_names();
            for (std::string t; std::getline(list, t, ',');)
                if (std::find(names.begin(), names.end(), t) == names.end())
                    return "unknown tree '" + t +
                           "' (auto, sah, median, none, bvh, rayquery, raypipeline)";
            return std::string();
        })
        ->capture_default_str();
    sub->add_option("--devices", a->device_counts,
                    "--throughput: rows of one image on the first N devices of each API, for "
                    "each N (1,2,4: the scaling table; speed-up against one)")
        ->delimiter(',')
        ->check(CLI::Range(1, 64));
    sub->add_option("--walk-steps", a->walk_steps,
                    "--throughput: rows for each count of node steps the BVH walk takes before "
                    "the lanes whose ray ended shade (MCPT_WALK_STEPS; 0: walked whole; "
                    "default: the device's choice)")
        ->delimiter(',')
        ->check(CLI::Range(0, 32));
    sub->add_option("--backend", a->backends,
                    "opencl|vulkan[:device], repeatable (default: every device found)");
    sub->add_option("--models", a->models, "Directory of models (scripts/fetch-models)")
        ->capture_default_str();
    sub->add_option("-o,--output", a->output, "Output prefix: prefix.md, .csv, .svg")
        ->capture_default_str();
    sub->add_option("--width", a->width, "Image width (default 256, quick 64)")
        ->check(CLI::Range(1, 16384));
    sub->add_option("--height", a->height, "Image height (default 256, quick 64)")
        ->check(CLI::Range(1, 16384));
    sub->add_option("--spp", a->spp, "Samples per pixel per frame (default 4, quick 2)")
        ->check(CLI::Range(1, 1000000));
    sub->add_option("--frames", a->frames, "Timed frames per configuration (median)")
        ->check(CLI::Range(1, 1000))
        ->capture_default_str();
    sub->add_option("--max-frame-seconds", a->max_frame_seconds,
                    "Skip configurations estimated slower than this (quick: at most 5)")
        ->check(CLI::PositiveNumber)
        ->capture_default_str();
    sub->callback([a] { run_bench(*a); });
}

void add_compare_command(CLI::App& app) {
    auto a = std::make_shared<CompareArgs>();
    CLI::App* sub = app.add_subcommand("compare", "A/B-test two backends on one scene");
    sub->add_option("scene", a->scene, "Built-in scene or .gltf/.glb file")->capture_default_str();
    add_lighting_options(sub, a->lighting);
    sub->add_option("--b-scene", a->b_scene,
                    "B renders this .gltf/.glb instead: the same scene in another encoding "
                    "(compressed, quantized); its camera and lights as the file has them");
    sub->add_option(
           "--a", a->a,
           "Backend A: opencl|vulkan[:device][,limits=phone][,tree=KIND]; several devices, "
           "comma-separated (opencl:0,opencl:1), render it together")
        ->capture_default_str();
    sub->add_option("--b", a->b, "Backend B, as --a")->capture_default_str();
    sub->add_option("--width", a->width)->check(CLI::Range(1, 4096))->capture_default_str();
    sub->add_option("--height", a->height)->check(CLI::Range(1, 4096))->capture_default_str();
    sub->add_option("--batches", a->batches, "Independent batches per backend")
        ->check(CLI::Range(2, 100000))
        ->capture_default_str();
    sub->add_option("--spp", a->spp, "Samples per pixel per batch")
        ->check(CLI::Range(1, 1000000))
        ->capture_default_str();
    sub->add_option("--same-seed-spp", a->same_seed_spp, "Samples per pixel of the same-seed test")
        ->check(CLI::Range(1, 1000000))
        ->capture_default_str();
    sub->add_option("--same-seed-limit", a->same_seed_limit,
                    "Fraction of pixels the same-seed renders may diverge in (rounding)")
        ->check(CLI::Range(0.0, 1.0))
        ->capture_default_str();
    sub->add_option("--max-depth", a->max_depth, "Bounces (default 8, or the scene's)");
    sub->add_option("--tree", a->tree,
                    std::string("Trace mode of both sides (a side's tree= option overrides): ") +
                        kTreeChoicesHelp)
        ->check(CLI::IsMember(tree_kind_names()))
        ->capture_default_str();
    sub->add_option("--alpha", a->alpha, "Family-wise false alarm rate")
        ->check(CLI::Range(1e-12, 0.5))
        ->capture_default_str();
    sub->add_option("-o,--output", a->output, "Write p-value / z / difference image (.exr)");
    sub->add_option(
           "--report", a->report,
           "Write a self-contained HTML report (verdicts, speed, images) to DIR/index.html")
        ->type_name("DIR");
    sub->add_flag("--parallel", a->parallel,
                  "Render A and B at once, each on its device (two GPUs: half the time)");
    sub->add_option("--b-light-scale", a->b_light_scale,
                    "Scale B's emitters (negative control: 1.02 must be detected)");
    sub->add_option("--b-defines", a->b_defines,
                    "Extra OpenCL defines for B (negative controls, e.g. "
                    "-DMCPT_NEGATIVE_CONTROL_NO_REFRACTION)");
    sub->callback([a] { run_compare(*a); });
}

void add_converge_command(CLI::App& app) {
    auto a = std::make_shared<ConvergeArgs>();
    CLI::App* sub = app.add_subcommand("converge", "Error against run time, per backend");
    sub->add_option("scene", a->scene, "Built-in scene or .gltf/.glb file")->capture_default_str();
    add_lighting_options(sub, a->lighting);
    sub->add_option("--backend", a->backends, "opencl|vulkan[:device], repeatable")
        ->capture_default_str();
    sub->add_option("--device", a->devices,
                    "Device index or name, repeatable: each backend's run renders one image on "
                    "all of them (api:device mixes APIs)");
    sub->add_flag("--beside-one", a->beside_one,
                  "With several devices: also a run on the first alone, the curve beside");
    sub->add_option("--width", a->width)->check(CLI::Range(1, 16384))->capture_default_str();
    sub->add_option("--height", a->height)->check(CLI::Range(1, 16384))->capture_default_str();
    sub->add_option("--time", a->seconds, "Render time per backend (s)")
        ->check(CLI::Range(1e-3, 1e7))
        ->capture_default_str();
    sub->add_option("--spp", a->max_spp, "Also stop at this many samples per pixel")
        ->check(CLI::Range(int64_t(1), int64_t(1000000000000)));
    sub->add_option("--checkpoints", a->checkpoints,
                    "geometric (1, 2, 4, ... spp) or time (time budget / 2^k)")
        ->check(CLI::IsMember({"geometric", "time"}))
        ->capture_default_str();
    sub->add_option("--reference", a->reference,
                    "auto (exact when known, else cached), exact, or cached")
        ->check(CLI::IsMember({"auto", "exact", "cached"}))
        ->capture_default_str();
    sub->add_option("--reference-spp", a->reference_spp, "Samples per pixel of a new reference")
        ->check(CLI::Range(16, 100000000))
        ->capture_default_str();
    sub->add_option("--target-rmse", a->targets, "Relative RMSE targets for time-to-error")
        ->check(CLI::Range(1e-9, 10.0))
        ->capture_default_str();
    sub->add_option("--max-depth", a->max_depth, "Bounces (default 8, or the scene's)")
        ->check(CLI::Range(0, 1000000));
    sub->add_option("--tree", a->tree, std::string("Trace mode: ") + kTreeChoicesHelp)
        ->check(CLI::IsMember(tree_kind_names()))
        ->capture_default_str();
    sub->add_option(
           "--seed", a->seed,
           "Seed of the first run (each further run adds 100000; --beside-one's takes its twin's)")
        ->capture_default_str();
    sub->add_option("--sampler", a->samplers,
                    "sobol (Owen-scrambled Sobol) and/or independent, one run per backend each")
        ->check(CLI::IsMember({"sobol", "independent"}))
        ->capture_default_str();
    sub->add_option("--sampling", a->sampling,
                    "uniform and/or adaptive (samples where the estimated noise is), one run "
                    "per backend and sampler each")
        ->check(CLI::IsMember({"uniform", "adaptive"}))
        ->capture_default_str();
    sub->add_option("-o,--output", a->output, "Output prefix: prefix.csv, prefix.svg")
        ->capture_default_str();
    sub->add_option("--report", a->report,
                    "Also write a self-contained HTML report (plot, tables, images) to "
                    "DIR/index.html")
        ->type_name("DIR");
    sub->callback([a] { run_converge(*a); });
}

void add_merge_command(CLI::App& app) {
    auto args = std::make_shared<MergeArgs>();
    CLI::App* sub = app.add_subcommand(
        "merge", "Add the checkpoints of a render in parts (render --part I/N) into one image");
    sub->add_option("parts", args->parts, "The parts' checkpoint files")->required();
    sub->add_option("-o,--output", args->output, "Output image (.exr linear, .png sRGB)")
        ->capture_default_str();
    sub->add_flag("--allow-missing", args->allow_missing,
                  "Merge the parts there are, saying how many samples are missing");
    sub->callback([args] { run_merge(*args); });
}

void add_render_command(CLI::App& app) {
    auto args = std::make_shared<RenderArgs>();
    CLI::App* sub = app.add_subcommand("render", "Render a built-in scene or a glTF file");
    sub->add_option("scene", args->scene, "Built-in scene (cornell, furnace) or .gltf/.glb file")
        ->capture_default_str();
    sub->add_option("--backend", args->backend, "opencl or vulkan")->capture_default_str();
    sub->add_option("--device", args->devices,
                    "Device index or name substring (mcpt devices), or api:device; repeated: "
                    "one image on several devices");
    sub->add_option("--limits", args->limits,
                    "Vulkan limits: device (as reported) or phone (Vulkan 1.1 minimums); "
                    "default $MCPT_VULKAN_LIMITS or device")
        ->check(CLI::IsMember({"device", "phone"}));
    auto* spp = sub->add_option("--spp", args->spp, "Samples per pixel (default 64)")
                    ->check(CLI::Range(
                        int64_t(1), int64_t(1000000000000)));  // as a number: "-1" is not 2^64 - 1
    sub->add_option("--time", args->seconds, "Render for this many seconds instead")
        ->excludes(spp)
        ->check(CLI::Range(1e-3, 1e7));
    sub->add_option("--target-error", args->target_error,
                    "Stop once mean standard error / mean radiance is below this (e.g. 0.05)")
        ->check(CLI::Range(1e-6, 1.0));
    sub->add_option("--width", args->width, "Image width")
        ->check(CLI::Range(1, 16384))
        ->capture_default_str();
    sub->add_option("--height", args->height, "Image height")
        ->check(CLI::Range(1, 16384))
        ->capture_default_str();
    sub->add_option("-o,--output", args->output, "Output image (.exr linear, .png sRGB)")
        ->capture_default_str();
    sub->add_option("--tree", args->tree, std::string("Trace mode: ") + kTreeChoicesHelp)
        ->check(CLI::IsMember(tree_kind_names()))
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
    sub->add_option("--sampler", args->sampler,
                    "sobol: Owen-scrambled Sobol points; independent: independent uniforms")
        ->check(CLI::IsMember({"sobol", "independent"}))
        ->capture_default_str();
    sub->add_flag("--reproducible", args->reproducible,
                  "The image depends only on the seed, the samples and the device, not on "
                  "timing (sums in fixed groups of 16 samples)");
    sub->add_flag("--adaptive", args->adaptive,
                  "Adaptive sampling: after 16 samples everywhere, samples where the estimated "
                  "noise is (--spp is then the mean over pixels)")
        ->excludes("--reproducible");
    sub->add_option("--checkpoint", args->checkpoint,
                    "Save the accumulation to this file (atomically) and resume from it when "
                    "it exists; implies --reproducible");
    sub->add_option("--checkpoint-every", args->checkpoint_every,
                    "Seconds between checkpoints (and one at the end)")
        ->check(CLI::Range(0.0, 1e7))
        ->capture_default_str();
    sub->add_option("--part", args->part,
                    "I/N: render part I of N of the --spp samples into --checkpoint (job "
                    "arrays; mcpt merge adds the parts)")
        ->needs(spp);
    sub->add_option("--chunk-seconds", args->chunk_seconds,
                    "Several devices: the duration of a chunk of samples handed to one")
        ->check(CLI::Range(0.01, 3600.0))
        ->capture_default_str();
    sub->add_option("--rank-timeout", args->rank_timeout,
                    "Under mpirun: the least time a rank is given to deliver a chunk or its "
                    "sums (each chunk's deadline is the larger of this and 10x its time at the "
                    "rank's measured speed; a rank's first chunk 10x this); a rank that misses "
                    "it ends the job, named")
        ->check(CLI::Range(0.01, 1e6))
        ->capture_default_str();
    sub->add_option("--reduction", args->reduction,
                    "Under mpirun: a round's sums reach rank 0 up a binomial tree (log2 N "
                    "steps), or flat (rank 0 adds every rank's in turn; to compare)")
        ->check(CLI::IsMember({"tree", "flat"}))
        ->capture_default_str();
    sub->add_option("--display-server", args->display_server,
                    "Stream the image to tev as it renders (tev's TCP protocol)")
        ->type_name("HOST:PORT");
    add_lighting_options(sub, args->lighting);
    sub->add_flag("-q,--quiet", args->quiet, "No progress bar");
    sub->add_flag("-v,--verbose", args->verbose, "Say what the build left out and why");
    sub->callback([args] { run_render(*args); });
}

void add_tree_command(CLI::App& app) {
    auto args = std::make_shared<TreeArgs>();
    CLI::App* sub =
        app.add_subcommand("tree", "Build a scene's k-d tree, report stats and work/ray");
    sub->add_option("scene", args->scene, "Built-in scene or .gltf/.glb file")
        ->capture_default_str();
    sub->add_option("--tree", args->tree, "sah, median, none or bvh")
        ->check(CLI::IsMember({"sah", "median", "none", "bvh"}))
        ->capture_default_str();
    sub->add_option("--depth", args->depth, "Depth limit (median: default 3)");
    sub->add_option("--rays", args->rays, "Rays per measurement")
        ->check(CLI::Range(1, 100000000))
        ->capture_default_str();
    sub->add_option("--warps", args->warps,
                    "Warps of 32 full paths for the model of a GPU warp's busy lanes (0: none)")
        ->check(CLI::Range(0, 100000))
        ->capture_default_str();
    sub->callback([args] { run_tree(*args); });
}

void add_view_command(CLI::App& app) {
    auto a = std::make_shared<ViewArgs>();
    CLI::App* sub = app.add_subcommand(
        "view", "Watch a render converge in the browser (A/B: --a SPEC --b SPEC)");
    sub->add_option("scene", a->scene, "Built-in scene or .gltf/.glb file")->capture_default_str();
    add_lighting_options(sub, a->lighting);
    sub->add_option("--backend", a->backend, "opencl or vulkan")->capture_default_str();
    sub->add_option("--device", a->devices,
                    "Device index or name substring (mcpt devices); repeated: one image on all");
    auto* opt_a = sub->add_option("--a", a->a,
                                  "A/B: side A, opencl|vulkan[:device][,limits=phone][,tree=KIND]; "
                                  "several: opencl:0,opencl:1");
    sub->add_option("--b", a->b, "A/B: side B, as --a")->needs(opt_a);
    sub->add_option("--b-light-scale", a->b_light_scale,
                    "Scale B's emitters (negative control: the z map must light up)")
        ->check(CLI::Range(0.0, 1e6));
    sub->add_option("--width", a->width)->check(CLI::Range(1, 16384))->capture_default_str();
    sub->add_option("--height", a->height)->check(CLI::Range(1, 16384))->capture_default_str();
    sub->add_option("--spp", a->spp, "Stop rendering at this many samples per pixel")
        ->check(CLI::Range(int64_t(1), int64_t(1000000000000)));
    sub->add_option("--time", a->seconds, "Quit after this many seconds (default: Ctrl-C)")
        ->check(CLI::Range(1e-3, 1e7));
    sub->add_option("--seed", a->seed, "Random seed (A and B share it)")->capture_default_str();
    sub->add_option("--max-depth", a->max_depth, "Bounces (default 8, or the scene's)")
        ->check(CLI::Range(0, 1000000));
    sub->add_option(
           "--tree", a->tree,
           std::string("Trace mode (a side's tree= option overrides): ") + kTreeChoicesHelp)
        ->check(CLI::IsMember(tree_kind_names()))
        ->capture_default_str();
    sub->add_option("--listen", a->listen,
                    "Address to serve on (127.0.0.1: this machine only; 0.0.0.0: every network, "
                    "with a warning: the token then travels over plain HTTP)")
        ->capture_default_str();
    sub->add_option("--port", a->port, "Port (0: any free one)")
        ->check(CLI::Range(0, 65535))
        ->capture_default_str();
    sub->callback([a] { run_view(*a); });
}

}  // namespace
}  // namespace mcpt

namespace {
// Under mpirun a failing rank ends the whole job (the others would wait for it forever).
int finish(int code) {
    if (code != 0 && mcpt::mpi_job().size > 1) {
        std::cerr.flush();
        mcpt::mpi_abort(code);
    }
    mcpt::mpi_finish();
    return code;
}
}  // namespace

int main(int argc, char** argv) {
    CLI::App app{"mcpt: Monte Carlo path tracer with a k-d tree (OpenCL reference, Vulkan port)"};
    app.require_subcommand(0, 1);
    mcpt::add_render_command(app);
    mcpt::add_devices_command(app);
    mcpt::add_tree_command(app);
    mcpt::add_compare_command(app);
    mcpt::add_converge_command(app);
    mcpt::add_bench_command(app);
    mcpt::add_merge_command(app);
    mcpt::add_view_command(app);
    try {
        mcpt::mpi_start(argc, argv);
        app.parse(argc, argv);
        // No subcommand: render the default scene on the best device.
        if (app.get_subcommands().empty()) app.get_subcommand("render")->parse("");
    } catch (const mcpt::ExitStatus& e) {
        // A verdict (compare: DIFFER), given when every rank has done its part.
        mcpt::mpi_finish();
        return e.code;
    } catch (const CLI::ParseError& e) {
        // CLI11's message; bad options are bad input: exit status 1 (--help: 0).
        return finish(app.exit(e) == 0 ? 0 : 1);
    } catch (const std::bad_alloc&) {
        // A size no check foresaw: say what ran out, still exit cleanly.
        std::cerr << "mcpt: error: out of host memory (an allocation failed)\n";
        return finish(1);
    } catch (const std::exception& e) {
        const int rank = mcpt::mpi_job().rank;
        std::cerr << "mcpt: error: "
                  << (mcpt::mpi_job().size > 1 ? "rank " + std::to_string(rank) + ": " : "")
                  << e.what() << "\n";
        return finish(1);
    }
    return finish(0);
}
