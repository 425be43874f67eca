// A scene packed into the device layout of gpu/shared_types.h: the arrays every backend
// uploads as they are, plus the scene part of GpuParams.
#pragma once
#include <cstdint>
#include <vector>

#include "common/accel/kdtree.h"
#include "common/gpu/shared_types.h"
#include "common/scene/scene.h"

namespace mcpt {

struct GpuScene {
    std::vector<gpu::KdNode> nodes;
    std::vector<uint32_t> leaf_indices;
    std::vector<gpu::GpuTriangle> triangles;
    std::vector<gpu::GpuSphere> spheres;
    std::vector<gpu::GpuMaterial> materials;
    std::vector<gpu::GpuLight> lights;  // alias table over emitters, by power
    gpu::GpuParams params{};            // scene fields set; per-dispatch fields zero
    uint32_t stack_size = 1;            // k-d traversal stack entries (tree depth + 1)
    uint32_t features = FEATURE_ALL;    // FEATURE_* bits the scene uses (scene_features.h)
    TreeStats tree_stats;
    TreeKind tree_kind = TreeKind::None;  // the tree packed (never Auto)
    std::string tree_choice;              // TreeKind::Auto: what it chose and why
    size_t device_bytes() const;          // total of all arrays
};

// Packs a validated scene and its tree. Throws mcpt::Error if the scene has no emitter.
GpuScene pack_scene(const Scene& scene, const KdTree& tree);

// The shared device buffers of shared_types.h (what both backends upload): the tree buffer
// (k-d nodes, then leaf indices) and the shading buffer (spheres, materials, lights), as
// 32-bit words. Never empty: one zero word stands for no data.
std::vector<uint32_t> tree_buffer(const GpuScene& scene);
std::vector<uint32_t> shading_buffer(const GpuScene& scene);

// Path-state slots for an image of npix pixels (one per pixel of a round's tile: the whole
// image up to MAX_STATE_SLOTS, within a device's largest buffer, MemoryLimits::
// max_buffer_bytes, 0 = unknown), and the bytes of its accumulation buffer: sums, path state
// and the active-slot counter.
uint32_t path_state_slots(uint64_t npix, uint64_t max_buffer_bytes);
uint64_t accum_buffer_bytes(uint64_t npix, uint64_t max_buffer_bytes);

// Pinhole camera for a width x height image into params.
void set_camera(gpu::GpuParams& params, const Camera& camera, int width, int height);

// Walker/Vose alias table over non-negative weights: prob/alias per slot, pmf per entry.
void build_alias_table(const std::vector<double>& weights, std::vector<gpu::GpuLight>& table);

}  // namespace mcpt
