// Leave out what a scene does not need: which device features (FEATURE_* of
// gpu/shared_types.h) a packed scene uses (whether it is worth a k-d tree at all is
// TreeKind::Auto in kdtree.h).
// Backends compile the path tracer for exactly these features (OpenCL -D switches, Vulkan
// specialization constants); a scene never runs a build that lacks one it uses.
#pragma once
#include <cstdint>
#include <string>

#include "common/accel/kdtree.h"

namespace mcpt {

struct DeviceInfo;
struct GpuScene;

// The features the packed scene uses: geometry kinds, the material kinds its primitives
// reference, its emitter kinds, and the k-d traversal when its tree has an interior node.
uint32_t scene_features(const GpuScene& scene);

// The --tree auto cost model of a device: SIMT for GPUs and Vulkan devices (lavapipe runs
// invocations as SIMD lanes), scalar for OpenCL CPU devices (PoCL).
TreeCostModel tree_cost_model(const DeviceInfo& device);

// "triangles, spheres, diffuse, ..." for the bits of mask, in bit order ("none" if empty).
std::string feature_names(uint32_t mask);

// What a build for `features` leaves out of the full kernel, in words.
std::string features_left_out(uint32_t features);

}  // namespace mcpt
