// From a validated scene to what one device renders: the tree options the commands give
// (tree_options: kind, depth, $MCPT_BVH_COLLAPSE), the tree (auto: the device's cost
// model decides, and the reason is kept), the packed device layout, and a check against the
// device's limits at the image size. Every client prepares a scene this way.
#pragma once
#include <string>

#include "common/accel/kdtree.h"
#include "common/render/backend.h"
#include "common/render/gpu_scene.h"
#include "common/scene/scene.h"

namespace mcpt {

// A tree kind name ("auto", "sah", "median", "none", "bvh") and depth limit (-1: the kind's default).
TreeOptions tree_options(const std::string& kind, int depth = -1);

// Builds the tree (TreeKind::Auto with `device`'s cost model), packs the scene and checks it
// against `device`'s limits for a width x height image. GpuScene::tree_kind and tree_choice
// record the tree it chose and why. Throws mcpt::Error.
GpuScene prepare_scene(const Scene& scene, const DeviceInfo& device, TreeOptions tree, int width,
                       int height);

// "sah: 1234 nodes, 567 leaves, depth 19, 2.1 refs/leaf, 3.20 ms, 12345 bytes".
std::string describe_tree(const GpuScene& scene);

}  // namespace mcpt
