// The mcpt subcommands: each registers its options on the CLI11 app and runs as a thin
// client of the engine (common/render/session.h, device_registry.h, prepare.h).
#pragma once
#include <CLI/CLI.hpp>
#include <string>
#include <vector>

#include "common/render/device_registry.h"
#include "common/render/prepare.h"
#include "common/render/session.h"
#include "common/scene/scene_load.h"

namespace mcpt {

// Thrown by a command to end mcpt with this exit status (e.g. compare's verdict).
struct ExitStatus {
    int code;
};

void add_render_command(CLI::App& app);
void add_devices_command(CLI::App& app);
void add_tree_command(CLI::App& app);
void add_compare_command(CLI::App& app);
void add_converge_command(CLI::App& app);
void add_bench_command(CLI::App& app);
void add_merge_command(CLI::App& app);
void add_view_command(CLI::App& app);

// --tree's help, after what the option is for: the choices and what auto picks.
inline constexpr const char* kTreeChoicesHelp =
    "auto (per device: the wide BVH, or no tree where the cost model prefers; never ray "
    "queries), sah, median, none, bvh (the wide BVH), rayquery (Vulkan devices with "
    "VK_KHR_ray_query: the driver traces)";

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
    std::string triangle_light_sampling = "solid-angle";  // solid-angle | area
    std::vector<float> background;
};

// Sets how `scene` picks lights, from --light-sampling: tree, power, contribution, or auto
// (Scene::auto_light_by_contribution, else Scene::auto_light_tree). Throws mcpt::Error where
// contribution is asked of a scene that cannot have it.
void apply_light_sampling(Scene& scene, const LightingArgs& lighting);
void add_lighting_options(CLI::App* sub, LightingArgs& a);
// The environment the options ask for (none: Environment{}). Throws mcpt::Error.
Environment lighting_environment(const LightingArgs& a);

}  // namespace mcpt
