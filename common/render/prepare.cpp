#include "common/render/prepare.h"

#include <algorithm>
#include <cstdio>

#include "common/env_integer.h"
#include "common/error.h"
#include "common/io/host_memory.h"
#include "common/render/device_limits.h"
#include "common/render/scene_features.h"
#include "common/scene/environment.h"

namespace mcpt {

TreeOptions tree_options(const std::string& kind, int depth) {
    TreeOptions o;
    o.kind = parse_tree_kind(kind);
    if (depth < -1 || depth > 60) throw Error("tree depth must be between 0 and 60 (-1: default)");
    o.max_depth = depth;
    // The BVH's collapse (measurements: 0 for the largest child opened first).
    if (const auto v =
            env_integer("MCPT_BVH_COLLAPSE", 0, 1, "0 (largest child first) or 1 (SAH-optimal)"))
        o.bvh_optimal_collapse = *v == 1;
    return o;
}

GpuScene prepare_scene(const Scene& scene, const DeviceInfo& device, TreeOptions tree, int width,
                       int height) {
    if (width <= 0 || height <= 0 || width > 16384 || height > 16384)
        throw Error("image size must be between 1x1 and 16384x16384");
    tree.auto_model = tree_cost_model(device);
    // The driver's tracing: Vulkan devices whose driver has it; auto does not pick it (yet).
    if (tree.kind == TreeKind::RayQuery && !device.ray_queries) {
        throw Error(device.label() + ": --tree rayquery needs a Vulkan device with ray queries (" +
                    (device.backend == "vulkan" ? "VK_KHR_ray_query; `mcpt devices` lists them"
                                                : "OpenCL has none") +
                    "); use --tree auto or bvh");
    }
    if (tree.kind == TreeKind::RayPipeline && !device.ray_pipelines) {
        throw Error(device.label() +
                    ": --tree raypipeline needs a Vulkan device with the ray-tracing pipeline (" +
                    (device.backend == "vulkan"
                         ? "VK_KHR_ray_tracing_pipeline; `mcpt devices` lists it"
                         : "OpenCL has none") +
                    "); use --tree auto or bvh");
    }
    const KdTree kd = build_kdtree(scene.triangles, tree);
    GpuScene g = pack_scene(scene, kd);
    // An environment map the shading buffer cannot hold is halved until it fits (lighting
    // keeps its mean; only its finest detail goes), with a warning: a phone still renders the
    // file. Refused only when the rest of the scene leaves no room.
    const MemoryLimits& m = device.memory;
    uint64_t limit = m.max_buffer_bytes;
    if (m.max_allocation_bytes > 0 && (limit == 0 || m.max_allocation_bytes < limit))
        limit = m.max_allocation_bytes;
    const uint64_t shading = shading_buffer_bytes(g);
    if (scene.environment.present() && limit > 0 && shading > limit) {
        const Environment& env = scene.environment;
        const uint64_t env_bytes = environment_device_bytes(env.width, env.height);
        const uint64_t rest = shading - std::min(shading, env_bytes);
        if (rest + 64 < limit) {
            Scene fitted = scene;
            shrink_environment(fitted.environment, limit - rest - 64);
            g = pack_scene(fitted, kd);
            g.warnings.push_back(
                "environment map " + env.name + " (" + std::to_string(env.width) + "x" +
                std::to_string(env.height) + ", " + human_bytes(env_bytes) +
                " on the device) exceeds " +
                (limit == m.max_buffer_bytes ? m.max_buffer_name : m.max_allocation_name) + " (" +
                human_bytes(limit) + ") with the scene: downsampled to " +
                std::to_string(fitted.environment.width) + "x" +
                std::to_string(fitted.environment.height) + " (mean radiance kept)");
        }
    }
    if (tree.kind == TreeKind::Auto && (device.ray_queries || device.ray_pipelines)) {
        g.tree_choice += device.ray_queries
                             ? "; ray queries not picked (auto never picks them: on lavapipe the "
                               "BVH traces faster; --tree rayquery to use them)"
                             : "; the ray-tracing pipeline not picked (auto never picks it: "
                               "on an H100, which has no RT cores, the BVH traces 1.3x to 3x "
                               "faster; --tree raypipeline to use it)";
    }
    check_device_limits(g, width, height, device, device.label());
    return g;
}

std::string describe_tree(const GpuScene& g) {
    const TreeStats& s = g.tree_stats;
    char buf[256];
    std::snprintf(buf, sizeof buf,
                  "%s: %zu nodes, %zu leaves, depth %d, %.1f refs/leaf, %.2f ms, %zu bytes",
                  tree_kind_name(g.tree_kind), s.nodes, s.leaves, s.max_depth, s.mean_leaf_size,
                  s.build_seconds * 1e3, s.bytes);
    return buf;
}

}  // namespace mcpt
