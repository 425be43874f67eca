#include "common/render/scene_features.h"

#include "common/render/backend.h"
#include "common/render/gpu_scene.h"

namespace mcpt {

namespace {

const char* const kFeatureNames[FEATURE_COUNT] = {
    "triangles",     "spheres",  "diffuse",           "mirror", "glass", "triangle lights",
    "sphere lights", "k-d tree", "microfacet",      "test NaN injection", "independent sampler"};

uint32_t material_feature(uint32_t type) {
    switch (type) {
        case MAT_MIRROR:
            return FEATURE_MIRROR;
        case MAT_GLASS:
            return FEATURE_GLASS;
        case MAT_PBR:
            return FEATURE_MICROFACET;
        default:
            return FEATURE_DIFFUSE;
    }
}

}  // namespace

uint32_t scene_features(const GpuScene& g) {
    uint32_t f = 0;
    // Geometry and the materials it references.
    if (!g.triangles.empty()) f |= FEATURE_TRIANGLES;
    if (!g.spheres.empty()) f |= FEATURE_SPHERES;
    for (const gpu::GpuTriangle& t : g.triangles)
        f |= material_feature(g.materials[t.material].type);
    for (const gpu::GpuSphere& s : g.spheres) f |= material_feature(g.materials[s.material].type);
    // Emitters.
    for (const gpu::GpuLight& l : g.lights)
        f |= (l.prim & LIGHT_SPHERE_BIT) ? FEATURE_SPHERE_LIGHTS : FEATURE_TRIANGLE_LIGHTS;
    // The tree, when it has more than one leaf.
    for (const gpu::KdNode& n : g.nodes)
        if ((n.flags & 3u) != KD_LEAF) f |= FEATURE_KDTREE;
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

}  // namespace mcpt
