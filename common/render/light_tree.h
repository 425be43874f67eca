// The light tree next-event estimation descends to pick a local light (emissive triangles and
// spheres, point and spot lamps) by its importance at the shading point (common/gpu/
// light_tree.h): a binary tree over the lights' bounds, power and cones of emission, split at
// the median of their centroids along the widest axis. Lights at infinity (directional, the environment) keep the
// alias table.
#pragma once
#include <cstdint>
#include <vector>

#include <glm/glm.hpp>

#include "common/gpu/shared_types.h"

namespace mcpt {

struct TreeLight {
    glm::vec3 lo, hi;  // bounds (a point for a lamp)
    double power;      // > 0
    uint32_t slot;     // in the light table
    // Where it emits: within acos(cos_o) of `axis` (unit), each point over a hemisphere about
    // its direction there. -1: every way (spheres, points).
    glm::vec3 axis{0.f, 0.f, 1.f};
    float cos_o = -1.f;
};

// The cone of directions that holds two cones (pbrt-v4's DirectionCone::Union).
struct DirectionCone {
    glm::vec3 axis{0.f, 0.f, 1.f};
    float cos_theta = -1.f;  // -1: every direction
};
DirectionCone cone_union(const DirectionCone& a, const DirectionCone& b);

struct LightTree {
    std::vector<gpu::GpuLightTreeNode> nodes;  // root first; children side by side
    // Per input light (in input order): the branches from the root to its leaf, bit k set when
    // the path goes to the second child at depth k.
    std::vector<uint32_t> trails;
    int depth = 0;
};

// Throws mcpt::Error past 32 levels (not reachable below 2^31 lights: the median split halves).
LightTree build_light_tree(const std::vector<TreeLight>& lights);

}  // namespace mcpt
