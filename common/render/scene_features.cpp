// What a scene uses (feature bits) and what each device compiles from it: the kernel's
// features, the tree cost model, the k-d steps, trace sites, the BVH walk's steps and NVIDIA's
// OpenCL register cap (backend.h) with their environment overrides, and the compile log
// ($MCPT_COMPILE_LOG).
#include "common/render/scene_features.h"

#include <cstdio>
#include <cstdlib>
#include <string>

#include "common/env_integer.h"
#include "common/error.h"
#include "common/render/backend.h"
#include "common/render/gpu_scene.h"

namespace mcpt {

namespace {

// clang-format off
const char* const kFeatureNames[FEATURE_COUNT] = {
    "triangles",     "spheres",  "diffuse",           "mirror", "glass", "triangle lights",
    "sphere lights", "k-d tree", "microfacet", "shading normals", "textures", "alpha mask",
    "punctual lights", "environment", "test NaN injection", "independent sampler",
    "light tree", "wide BVH", "lights by contribution", "volume", "clearcoat", "sheen",
    "rectangle lights"};
// clang-format on

// The features of a material: its kind, then its textures and alpha mask.
uint32_t material_features(const gpu::GpuMaterial& m) {
    uint32_t f = 0;
    if (m.tex_base != NO_TEXTURE || m.tex_metal_rough != NO_TEXTURE || m.tex_emission != NO_TEXTURE)
        f |= FEATURE_TEXTURES;
    if (m.tex_normal != NO_TEXTURE) f |= FEATURE_TEXTURES | FEATURE_SHADING_NORMALS;
    if (m.alpha_cutoff > 0.f) f |= FEATURE_ALPHA_MASK;
    if (m.type & MAT_VOLUME) f |= FEATURE_VOLUME;
    if ((m.type & MAT_KIND_MASK) == MAT_PBR && m.clearcoat > 0.f) f |= FEATURE_CLEARCOAT;
    if ((m.type & MAT_KIND_MASK) == MAT_PBR &&
        (m.sheen_r > 0.f || m.sheen_g > 0.f || m.sheen_b > 0.f))
        f |= FEATURE_SHEEN;
    if ((m.tex_clearcoat & m.tex_sheen) != NO_TEXTURE) f |= FEATURE_TEXTURES;  // (all 1s: none)
    switch (m.type & MAT_KIND_MASK) {
        case MAT_MIRROR:
            return f | FEATURE_MIRROR;
        case MAT_GLASS:
            return f | FEATURE_GLASS;
        case MAT_PBR:
        case MAT_ROUGH_GLASS:
            return f | FEATURE_MICROFACET;
        default:
            return f | FEATURE_DIFFUSE;
    }
}

}  // namespace

uint32_t scene_features(const GpuScene& g) {
    uint32_t f = 0;
    // Geometry and the materials it references.
    if (!g.triangles.empty()) f |= FEATURE_TRIANGLES;
    if (!g.spheres.empty()) f |= FEATURE_SPHERES;
    // (textures on spheres have no coordinates: only triangles bring texture features)
    const uint32_t texture_bits = FEATURE_TEXTURES | FEATURE_SHADING_NORMALS | FEATURE_ALPHA_MASK;
    for (const gpu::GpuTriangle& t : g.triangles) f |= material_features(g.materials[t.material]);
    for (const gpu::GpuSphere& s : g.spheres)
        f |= material_features(g.materials[s.material]) & ~texture_bits;
    if (g.vertex_normals) f |= FEATURE_SHADING_NORMALS;
    // Emitters.
    for (const gpu::GpuLight& l : g.lights)
        f |= (l.prim & LIGHT_PUNCTUAL_BIT) ? FEATURE_PUNCTUAL_LIGHTS
             : l.prim == LIGHT_ENVIRONMENT ? FEATURE_ENVIRONMENT
             : (l.prim & LIGHT_SPHERE_BIT) ? FEATURE_SPHERE_LIGHTS
             : (g.materials[g.triangles.at(l.prim).material].type & MAT_RECT_LIGHT)
                 ? FEATURE_RECT_LIGHTS
                 : FEATURE_TRIANGLE_LIGHTS;
    if (g.params.num_tree_lights > 0) f |= FEATURE_LIGHT_TREE;
    if (g.params.scene_flags & SCENE_LIGHT_CONTRIBUTION) f |= FEATURE_LIGHT_CONTRIBUTION;
    // The environment is seen by rays that escape, even when it is black.
    if (g.params.env_width > 0) f |= FEATURE_ENVIRONMENT;
    // The tree: the BVH, or the k-d tree when it has more than one leaf.
    if (g.tree_kind == TreeKind::Bvh) {
        f |= FEATURE_BVH;
    } else {
        for (const gpu::KdNode& n : g.nodes)
            if ((n.flags & 3u) != KD_LEAF) f |= FEATURE_KDTREE;
    }
    return f;
}

TreeCostModel tree_cost_model(const DeviceInfo& d) {
    return d.backend == "opencl" && d.type == "cpu" ? kScalarCostModel : kSimtCostModel;
}

std::string feature_names(uint32_t mask) {
    std::string s;
    for (int i = 0; i < FEATURE_COUNT; ++i) {
        if (!(mask & (1u << i))) continue;
        if (!s.empty()) s += ", ";
        s += kFeatureNames[i];
    }
    return s.empty() ? "none" : s;
}

std::string features_left_out(uint32_t features) {
    const uint32_t out = FEATURE_ALL & ~features;
    return out == 0 ? "nothing (the scene uses every feature)" : feature_names(out);
}

uint32_t compile_features(const BackendOptions& options, const GpuScene& scene) {
    const uint32_t f = options.features != 0 ? options.features : scene.features;
    return (f & FEATURE_BITS) | (options.compile_nonce << FEATURE_COUNT);
}

void log_compile(const char* api, double seconds, const std::string& settings) {
    const char* path = std::getenv("MCPT_COMPILE_LOG");
    if (!path || !*path) return;
    // One write per line (O_APPEND): the processes of a parallel test run interleave whole
    // lines.
    const std::string line =
        std::string(api) + "\t" + std::to_string(seconds) + "\t" + settings + "\n";
    if (std::FILE* f = std::fopen(path, "a")) {
        std::fwrite(line.data(), 1, line.size(), f);
        std::fclose(f);
    }
}

KdSteps kd_steps(const DeviceInfo&) {
    // One of each, overlapped, on every device measured (docs/traversal.md).
    KdSteps s;
    s.nodes = uint32_t(env_integer("MCPT_KD_NODE_STEPS", 1, 32).value_or(s.nodes));
    s.triangles = uint32_t(env_integer("MCPT_KD_TRI_STEPS", 1, 32).value_or(s.triangles));
    s.overlap = uint32_t(env_integer("MCPT_KD_OVERLAP", 0, 1).value_or(s.overlap));
    return s;
}

namespace {
bool is_nvidia(const DeviceInfo& device) {
    return device.platform.find("NVIDIA") != std::string::npos ||
           device.name.find("NVIDIA") != std::string::npos;
}
}  // namespace

uint32_t walk_steps(const DeviceInfo& device, uint32_t features, bool driver_traced,
                    uint32_t tree_depth) {
    if (driver_traced || (features & FEATURE_BVH) == 0) return 0;
    if (const std::optional<long> n = env_integer("MCPT_WALK_STEPS", 0, 32)) return uint32_t(*n);
    // Measured on an H100 (1024², M rays/s, walked whole against 4 steps; docs/traversal.md):
    // NVIDIA's Vulkan bunny +17%, dragon-48k +14%, dragon-871k +8%; the textured scene
    // level; the Cornell box and the materials scene -9% and -16%. Their BVHs' depths, by the
    // optimal collapse (one more than the largest-child-first trees measured then): 6, 7 and
    // 11; 5; 0 and 0. NVIDIA's OpenCL walks with a cap of 128 registers (nvidia_register_cap).
    // Other GPUs and the CPU devices (lavapipe -11%, PoCL -2%): not walked.
    return device.type == "gpu" && is_nvidia(device) && tree_depth >= 6 ? 4u : 0u;
}

uint32_t nvidia_register_cap(uint32_t features, uint32_t walk) {
    const char* const caps = "0 (no cap) or 16 to 255";
    if (const std::optional<long> n = env_integer("MCPT_NV_MAXRREGCOUNT", 0, 255, caps)) {
        if (*n != 0 && *n < 16) refuse_env("MCPT_NV_MAXRREGCOUNT", caps);
        return uint32_t(*n);
    }
    // H100, 1024², M rays/s (docs/traversal.md): walked, 128 against none, dragon-871k 2,046
    // against 1,777, dragon-48k 2,640 against 2,282, bunny 2,734 against 2,421 (96: between);
    // walked whole, 96 against 56, the Cornell box 5,212 against 4,504, the materials scene
    // 3,584 against 3,285; the textured scene 1,448 at 56, 1,226 at 96, 1,137 uncapped. The
    // k-d tree's 56: 13-43% faster than uncapped (docs/benchmarks.md).
    if ((features & FEATURE_BVH) == 0) return 56;
    if (walk != 0) return 128;
    return (features & FEATURE_TEXTURES) != 0 ? 56 : 96;
}

uint32_t trace_sites(const DeviceInfo& device, uint32_t features, bool ray_pipeline,
                     uint32_t tree_depth) {
    if (walk_steps(device, features, ray_pipeline, tree_depth) > 0) return 1u;
    if (const std::optional<long> n = env_integer("MCPT_TRACE_SITES", 1, 2)) {
        return uint32_t(*n);
    }
    // One site measured (1024², H100): NVIDIA's Vulkan on the textured scene 688 -> 858 M
    // rays/s, on the meshes and the Cornell box -5% to +2%; NVIDIA's OpenCL 2-7x slower (the
    // register cap), PoCL and lavapipe 18-63% slower. Through the k-d tree (H200, 2026-11-28)
    // NVIDIA's Vulkan gained with one site on every scene: the meshes +4 to +6%, the Cornell
    // box +29%, the materials scene +15%; through the BVH the meshes -8 to +1%, no tree -7 to
    // -9% (docs/traversal.md). Through the ray-tracing pipeline (H100, 1024², 2026-12-07):
    // the Cornell box 908 -> 2,776 M rays/s, the 871k dragon 657 -> 1,167; lavapipe's 10%
    // slower with one (the textured scene).
    const bool nvidia = is_nvidia(device);
    const bool one = (features & (FEATURE_TEXTURES | FEATURE_KDTREE)) != 0 || ray_pipeline;
    return device.backend == "vulkan" && nvidia && one ? 1u : 2u;
}

}  // namespace mcpt
