// A scene packed into the device layout of gpu/shared_types.h: the arrays every backend
// uploads as they are, plus the scene part of GpuParams.
#pragma once
#include <cstdint>
#include <string>
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
    std::vector<gpu::GpuLight> lights;                   // alias table over emitters, by power
    std::vector<gpu::GpuTriangleAttributes> attributes;  // empty, or one per triangle
    std::vector<gpu::GpuTexture> textures;
    // The texel region: texture texels (RGBA halves, two words each), then the punctual lights
    // and the environment (shared_types.h: GpuParams.punctual_word, env_*).
    std::vector<uint32_t> texels;
    bool vertex_normals = false;      // attributes carry the scene's vertex normals
    gpu::GpuParams params{};          // scene fields set; per-dispatch fields zero
    uint32_t stack_size = 1;          // k-d traversal stack entries (tree depth + 1)
    uint32_t features = FEATURE_ALL;  // FEATURE_* bits the scene uses (scene_features.h)
    TreeStats tree_stats;
    TreeKind tree_kind = TreeKind::None;  // the tree packed (never Auto)
    std::string tree_choice;              // TreeKind::Auto: what it chose and why
    std::vector<std::string> warnings;    // what preparing it changed (a downsampled map)
    size_t device_bytes() const;          // total of all arrays
};

// Packs a validated scene and its tree. Throws mcpt::Error if the scene has no emitter.
GpuScene pack_scene(const Scene& scene, const KdTree& tree);

// The shared device buffers of shared_types.h (what both backends upload): the tree buffer
// (k-d nodes, then leaf indices) and the shading buffer (spheres, materials, lights, textures
// and texels), as
// 32-bit words. Never empty: one zero word stands for no data.
std::vector<uint32_t> tree_buffer(const GpuScene& scene);
std::vector<uint32_t> shading_buffer(const GpuScene& scene);
uint64_t shading_buffer_bytes(const GpuScene& scene);
// The triangle buffer: the triangles, then their attributes (when the scene has any).
std::vector<uint32_t> triangle_buffer(const GpuScene& scene);

// A unit vector in octahedral snorm16x2 form (gpu::normal_from_oct decodes it).
uint32_t oct_encode(glm::vec3 n);
// A scene material as the devices read it.
gpu::GpuMaterial pack_material(const Material& m);

// The accumulation buffer of an image of npix pixels on a device whose largest buffer is
// max_buffer_bytes (MemoryLimits::max_buffer_bytes; 0 = unknown): the sums of every pixel and
// one path-state slot per pixel of a round's tile (the whole image up to MAX_STATE_SLOTS, as
// many as fit); or, when not even the sums fit, a window of `slots` pixels with their sums
// and slots, which a round's tile never exceeds and the host reads back after each round.
// With exact_sums (reproducible renders) and no window, the exact sums of every pixel follow
// (EXACT_VEC4_PER_PIXEL vec4 each) where they fit within max_buffer_bytes.
struct AccumLayout {
    bool window = false;
    uint32_t sum_pixels = 0;    // pixels whose sums the buffer holds (npix, or slots)
    uint32_t slots = 0;         // path-state slots: the largest tile
    uint32_t exact_pixels = 0;  // pixels whose exact sums the buffer holds (npix, or 0)
    uint64_t bytes = 0;         // sums, path state, the pending word, the sample plan, exact sums
    uint64_t sums_bytes() const { return uint64_t(sum_pixels) * ACCUM_VEC4_PER_PIXEL * 16; }
    uint64_t pending_offset() const {
        return sums_bytes() + uint64_t(slots) * PATH_STATE_VEC4 * 16;
    }
    uint64_t plan_offset() const { return pending_offset() + 16; }
    uint64_t plan_bytes() const { return uint64_t(slots) * PLAN_WORDS_PER_SLOT * 4; }
    uint64_t exact_bytes() const { return uint64_t(exact_pixels) * EXACT_VEC4_PER_PIXEL * 16; }
    uint64_t exact_offset() const { return bytes - exact_bytes(); }  // a multiple of 16
};
AccumLayout accum_layout(uint64_t npix, uint64_t max_buffer_bytes, bool exact_sums = false);
// ", accumulation in windows of N pixels" for a windowed layout (Backend::layout()), ", exact
// sums on the device" for one with exact sums, else "".
std::string window_note(const AccumLayout& layout);

// Pinhole camera for a width x height image into params.
void set_camera(gpu::GpuParams& params, const Camera& camera, int width, int height);

// Walker/Vose alias table over non-negative weights: prob/alias per slot, pmf per entry.
void build_alias_table(const std::vector<double>& weights, std::vector<gpu::GpuLight>& table);

}  // namespace mcpt
