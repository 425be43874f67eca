#include "common/render/prepare.h"

#include <cstdio>

#include "common/error.h"
#include "common/render/device_limits.h"
#include "common/render/scene_features.h"

namespace mcpt {

TreeOptions tree_options(const std::string& kind, int depth) {
    TreeOptions o;
    o.kind = parse_tree_kind(kind);
    if (depth < -1 || depth > 60) throw Error("tree depth must be between 0 and 60 (-1: default)");
    o.max_depth = depth;
    return o;
}

GpuScene prepare_scene(const Scene& scene, const DeviceInfo& device, TreeOptions tree, int width,
                       int height) {
    if (width <= 0 || height <= 0 || width > 16384 || height > 16384)
        throw Error("image size must be between 1x1 and 16384x16384");
    tree.auto_model = tree_cost_model(device);
    GpuScene g = pack_scene(scene, build_kdtree(scene.triangles, tree));
    check_device_limits(g, width, height, device, device.backend + ": " + device.name);
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
