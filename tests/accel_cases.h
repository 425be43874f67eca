// Meshes and rays that test every acceleration structure (kdtree_test.cpp,
// wide_bvh_test.cpp): random soups, a bumpy closed blob, stairs on integer planes, a flat
// grid, stacked copies of one triangle; random, axis-aligned, in-plane, through-vertex and
// along-edge rays.
#pragma once
#include <string>
#include <vector>

#include "common/gpu/shared_types.h"
#include "common/scene/scene.h"

namespace mcpt {

Triangle tri(glm::vec3 a, glm::vec3 b, glm::vec3 c);
std::vector<Triangle> random_soup(int n, uint32_t seed);
std::vector<Triangle> blob(int n, float bump = 0.12f);
std::vector<Triangle> stairs(int steps);
std::vector<Triangle> flat_grid(int n);
std::vector<Triangle> stacked(int count);

struct NamedMesh {
    std::string name;
    std::vector<Triangle> tris;
};
// soup, blob, stairs, flat, stacked, blob+pile.
std::vector<NamedMesh> test_meshes();
Bounds bounds_of(const std::vector<Triangle>& tris);

struct TestRay {
    glm::vec3 o, d;
};
// Random rays aimed into the bounds, axis-aligned rays (zero components of both signs, some
// starting on integer planes), rays lying in integer planes, rays through vertices and rays
// along edges.
std::vector<TestRay> test_rays(const std::vector<Triangle>& tris, uint32_t seed);

// The triangles as the device reads them (material 0).
std::vector<gpu::GpuTriangle> device_triangles(const std::vector<Triangle>& tris);
std::string describe_ray(const TestRay& r);

}  // namespace mcpt
