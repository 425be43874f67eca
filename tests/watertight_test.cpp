// Watertightness through the shared device traversal (compiled for the CPU): rays aimed
// exactly at the shared vertices and edges of a closed mesh never slip through, for every
// tree kind, from inside and from outside.
#include <gtest/gtest.h>

#include "common/accel/cpu_trace.h"
#include "test_scenes.h"

namespace mcpt {
namespace {

// Rays from inside and outside through every vertex and edge midpoint; returns the misses.
size_t misses_through_edges(TreeKind kind, float shrink) {
    Scene scene = make_bumpy_sphere_scene(24);
    // Keep only the closed bumpy mesh (the last material) and one light triangle.
    std::vector<Triangle> mesh;
    for (const Triangle& t : scene.triangles)
        if (t.material == scene.materials.size() - 1) mesh.push_back(t);
    // Shrinking each triangle toward its centroid opens cracks (the negative control).
    for (Triangle& t : mesh) {
        const glm::vec3 c = (t.v0 + t.v1 + t.v2) / 3.f;
        t.v0 += shrink * (c - t.v0), t.v1 += shrink * (c - t.v1), t.v2 += shrink * (c - t.v2);
    }
    std::vector<Triangle> targets_from = scene.triangles = mesh;
    Material light;
    light.emission = glm::vec3(1.f);
    scene.spheres = {{glm::vec3(0.f, 3.f, 0.f), 0.1f, scene.add_material(light)}};
    validate_scene(scene);
    TreeOptions opt;
    opt.kind = kind;
    const GpuScene g = pack_scene(scene, build_kdtree(scene.triangles, opt));

    const glm::vec3 inside(0.013f, 0.507f, -0.011f);
    size_t rays = 0, missed = 0;
    auto shoot = [&](glm::vec3 from, glm::vec3 target) {
        gpu::Ray r;
        r.o = from;
        r.d = glm::normalize(target - from);
        r.tmax = 3.4e38f;
        ++rays;
        missed += cpu_trace(g, r, false).prim == NO_HIT;
    };
    for (const Triangle& t0 : targets_from) {
        // Aim at the unshrunk mesh's vertices and edges.
        const glm::vec3 c = (t0.v0 + t0.v1 + t0.v2) / 3.f;
        Triangle t = t0;
        if (shrink > 0) {
            const float k = shrink / (1 - shrink);
            t.v0 += k * (t0.v0 - c), t.v1 += k * (t0.v1 - c), t.v2 += k * (t0.v2 - c);
        }
        const glm::vec3 targets[] = {
            t.v0, t.v1, t.v2, 0.5f * (t.v0 + t.v1), 0.5f * (t.v1 + t.v2), 0.5f * (t.v2 + t.v0)};
        for (const glm::vec3& target : targets) {
            shoot(inside, target);
            // From outside, along the same line through the surface point.
            shoot(inside + 4.f * (target - inside), target);
        }
    }
    return missed;
}

class Watertight : public ::testing::TestWithParam<TreeKind> {};

TEST_P(Watertight, RaysThroughVerticesAndEdgesHit) {
    EXPECT_EQ(misses_through_edges(GetParam(), 0.f), 0u) << "rays slipped through";
}

TEST_P(Watertight, NegativeControlCracksAreFound) {
    EXPECT_GT(misses_through_edges(GetParam(), 1e-3f), 1000u);
}

INSTANTIATE_TEST_SUITE_P(Trees, Watertight,
                         ::testing::Values(TreeKind::Sah, TreeKind::Median, TreeKind::None),
                         [](const auto& info) { return std::string(tree_kind_name(info.param)); });

}  // namespace
}  // namespace mcpt
