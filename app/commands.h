// The mcpt subcommands: each registers its options on the CLI11 app and runs.
#pragma once
#include <CLI/CLI.hpp>
#include <memory>
#include <string>

#include "common/backend.h"

#include "common/kdtree.h"
#include "common/scene.h"

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

// A built-in scene name or a .gltf/.glb path, loaded and validated; warnings go to stderr.
Scene load_scene_argument(const std::string& arg);

// "opencl", "vulkan", or either with ":device" (index or name substring).
std::unique_ptr<Backend> open_backend(const std::string& spec, BackendOptions options);

// --tree and --depth into TreeOptions.
TreeOptions tree_options(const std::string& kind, int depth);

}  // namespace mcpt
