// Tests of the 8-wide BVH (common/accel/wide_bvh.h) and its shared traversal
// (common/gpu/traverse_bvh.h) on the CPU: every triangle in exactly one leaf inside every box
// above it, the same tree on any thread count, and closest hits equal bit for bit to brute
// force and to the k-d tree on the k-d tests' meshes and rays, at extreme scales and far from
// the origin (kdtree_test.cpp runs its device-traversal checks, any hit included, on the BVH
// too). The negative control: a BVH whose leaf boxes stop one grid cell
// short of their triangles is caught by rays that meet only that cell. Both collapses (the
// SAH-optimal one against the largest child first: a lower SAH cost, fewer nodes, the same tree
// at every scale). Also the models of a GPU warp and work-group that `mcpt tree --warps`
// prints (per-ray visit logs, lanes busy, the walk, the regroup), worked by hand.
#include "common/accel/wide_bvh.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <functional>
#include <string>
#include <vector>

#include "accel_cases.h"
#include "common/accel/cpu_trace.h"
#include "common/render/gpu_scene.h"
#include "common/scene/builtin_scenes.h"
#include "common/gpu/traverse.h"

namespace mcpt {
namespace {

using glm::vec3;

TreeOptions bvh_options(int threads = 0, bool optimal_collapse = true) {
    TreeOptions o;
    o.kind = TreeKind::Bvh;
    o.threads = threads;
    o.bvh_optimal_collapse = optimal_collapse;
    return o;
}

// Hits must agree bit for bit: triangle, distance and barycentrics.
::testing::AssertionResult same_hit(const gpu::Hit& a, const gpu::Hit& b) {
    if (a.status != b.status) return ::testing::AssertionFailure() << "status " << a.status << " / " << b.status;
    if (a.prim != b.prim)
        return ::testing::AssertionFailure() << "triangle " << a.prim << " at " << a.t << " / " << b.prim << " at " << b.t;
    if (a.prim == NO_HIT) return ::testing::AssertionSuccess();
    if (std::memcmp(&a.t, &b.t, 4) != 0 || std::memcmp(&a.b1, &b.b1, 4) != 0 || std::memcmp(&a.b2, &b.b2, 4) != 0)
        return ::testing::AssertionFailure() << "t " << a.t << " / " << b.t;
    return ::testing::AssertionSuccess();
}

gpu::Ray device_ray(const TestRay& r) {
    gpu::Ray ray;
    ray.o = r.o, ray.d = r.d, ray.tmax = 3.0e38f;
    return ray;
}

// Every node and its children: each triangle's bounds inside the boxes of every child above
// it; each finite triangle in exactly one leaf.
void check_structure(const KdTree& bvh, const std::vector<Triangle>& tris, const std::string& what) {
    std::vector<int> seen(tris.size(), 0);
    std::function<void(uint32_t, int, std::vector<BvhChild>&)> walk =
        [&](uint32_t node, int depth, std::vector<BvhChild>& above) {
            ASSERT_LE(depth, bvh.stats.max_depth) << what;
            for (const BvhChild& c : bvh_children(bvh_node(bvh, node))) {
                above.push_back(c);
                if (c.internal) {
                    ASSERT_LT(c.index, bvh_node_count(bvh)) << what;
                    walk(c.index, depth + 1, above);
                } else {
                    ASSERT_GE(c.triangles, 1u);
                    ASSERT_LE(c.triangles, BVH_LEAF_MAX);
                    for (uint32_t k = 0; k < c.triangles; ++k) {
                        const uint32_t t = bvh.leaf_indices.at(c.index + k);
                        seen.at(t) += 1;
                        for (const BvhChild& box : above)
                            for (const vec3& v : {tris[t].v0, tris[t].v1, tris[t].v2})
                                for (int a = 0; a < 3; ++a) {
                                    ASSERT_LE(box.lo[a], double(v[a])) << what << ": triangle " << t;
                                    ASSERT_GE(box.hi[a], double(v[a])) << what << ": triangle " << t;
                                }
                    }
                }
                above.pop_back();
            }
        };
    std::vector<BvhChild> above;
    walk(0, 0, above);
    for (size_t t = 0; t < tris.size(); ++t) ASSERT_EQ(seen[t], 1) << what << ": triangle " << t;
    EXPECT_EQ(bvh.leaf_indices.size(), tris.size()) << what;
    EXPECT_LE(bvh.stack_size(), KD_STACK_SIZE) << what;
}

TEST(WideBvhBuild, EveryTriangleOnceInsideEveryBoxAbove) {
    for (const bool optimal : {true, false})
        for (const NamedMesh& m : test_meshes()) {
            const KdTree bvh = build_kdtree(m.tris, bvh_options(0, optimal));
            EXPECT_EQ(bvh.kind, TreeKind::Bvh);
            check_structure(bvh, m.tris, m.name + (optimal ? "" : ", largest child first"));
            if (HasFatalFailure()) return;
        }
    for (int n : {0, 1, 2, 3, 4, 9, 25}) {
        const std::vector<Triangle> tris = random_soup(n, 7);
        const KdTree bvh = build_kdtree(tris, bvh_options());
        check_structure(bvh, tris, std::to_string(n) + " triangles");
        EXPECT_GE(bvh_node_count(bvh), 1u);
    }
}

TEST(WideBvhBuild, SameTreeForEveryThreadCount) {
    const std::vector<Triangle> tris = blob(40);  // 19,200 triangles: subtrees on threads
    const KdTree one = build_kdtree(tris, bvh_options(1));
    for (int threads : {2, 3, 8}) {
        const KdTree many = build_kdtree(tris, bvh_options(threads));
        ASSERT_EQ(many.nodes.size(), one.nodes.size()) << threads;
        EXPECT_EQ(std::memcmp(many.nodes.data(), one.nodes.data(), one.nodes.size() * 8), 0) << threads;
        EXPECT_EQ(many.leaf_indices, one.leaf_indices) << threads;
    }
}

// A node of at most four leaves and no internal child keeps them in slots 0-3, so the
// traversal tests one half of four slots (its second meta word is 0).
TEST(WideBvhBuild, SmallLeafNodesUseTheFirstHalf) {
    const KdTree bvh = build_kdtree(blob(20), bvh_options());
    size_t small = 0;
    for (uint32_t i = 0; i < bvh_node_count(bvh); ++i) {
        const gpu::BvhNode node = bvh_node(bvh, i);
        const std::vector<BvhChild> kids = bvh_children(node);
        const bool leaves_only =
            std::none_of(kids.begin(), kids.end(), [](const BvhChild& c) { return c.internal; });
        if (!leaves_only || kids.size() > BVH_WIDTH / 2) continue;
        small += 1;
        for (const BvhChild& c : kids) EXPECT_LT(c.slot, int(BVH_WIDTH / 2)) << "node " << i;
        EXPECT_EQ(node.words[7], 0u) << "node " << i;
    }
    EXPECT_GT(small, bvh_node_count(bvh) / 4);  // most nodes, as on the meshes
}

// Closest hits: the BVH, the k-d tree and brute force agree bit for bit (ties go to the lower
// triangle index in all three), on every test mesh and ray.
TEST(WideBvhTraversal, ClosestHitEqualsBruteForceAndKdTree) {
    size_t hits = 0;
    for (const NamedMesh& m : test_meshes()) {
        const std::vector<gpu::GpuTriangle> g = device_triangles(m.tris);
        const KdTree bvh = build_kdtree(m.tris, bvh_options());
        const KdTree largest_first = build_kdtree(m.tris, bvh_options(0, false));
        TreeOptions kd_options;
        const KdTree kd = build_kdtree(m.tris, kd_options);
        for (uint32_t seed : {21u, 22u}) {
            for (const TestRay& r : test_rays(m.tris, seed)) {
                const gpu::Ray ray = device_ray(r);
                const gpu::Hit expected = brute_force_hit(g, ray);
                const gpu::Hit b = cpu_trace_tree(bvh, g, ray);
                ASSERT_TRUE(same_hit(b, expected)) << m.name << ": " << describe_ray(r) << " (BVH / brute force)";
                ASSERT_TRUE(same_hit(cpu_trace_tree(largest_first, g, ray), expected))
                    << m.name << ": " << describe_ray(r)
                    << " (BVH, largest child first / brute force)";
                ASSERT_TRUE(same_hit(cpu_trace_tree(kd, g, ray), expected))
                    << m.name << ": " << describe_ray(r) << " (k-d tree / brute force)";
                hits += expected.prim != NO_HIT;
            }
        }
    }
    EXPECT_GT(hits, 1000u);
}

// The same at extreme scales and far from the origin: quantized boxes stay conservative.
TEST(WideBvhTraversal, ExactAtExtremeScalesAndPositions) {
    for (float scale : {1e-4f, 1.f, 1e4f}) {
        for (float offset : {0.f, 1e3f * scale}) {
            std::vector<Triangle> tris = blob(12);
            for (Triangle& t : tris)
                for (vec3* v : {&t.v0, &t.v1, &t.v2}) *v = *v * scale + vec3(offset, -offset, 0.5f * offset);
            const std::vector<gpu::GpuTriangle> g = device_triangles(tris);
            const KdTree bvh = build_kdtree(tris, bvh_options());
            check_structure(bvh, tris, "scaled");
            size_t hits = 0;
            for (const TestRay& r : test_rays(tris, 31)) {
                const gpu::Ray ray = device_ray(r);
                const gpu::Hit expected = brute_force_hit(g, ray);
                ASSERT_TRUE(same_hit(cpu_trace_tree(bvh, g, ray), expected))
                    << "scale " << scale << ", offset " << offset << ": " << describe_ray(r);
                hits += expected.prim != NO_HIT;
            }
            EXPECT_GT(hits, 100u) << scale << " " << offset;
        }
    }
}

// Rays that meet a leaf's triangles only within the last grid cell of its box on x: from an
// origin beyond that cell's inner plane, into the triangle near its vertex of largest x.
struct CellRay {
    gpu::Ray ray;
    uint32_t node = 0;
    int slot = 0;
    uint32_t q_short = 0;  // the plane one cell short of the content
};
std::vector<CellRay> last_cell_rays(const KdTree& bvh, const std::vector<Triangle>& tris) {
    std::vector<CellRay> out;
    for (uint32_t n = 0; n < bvh_node_count(bvh); ++n) {
        const gpu::BvhNode node = bvh_node(bvh, n);
        float p;
        std::memcpy(&p, &node.words[0], 4);
        const double cell = std::ldexp(1.0, int(node.words[3] & 0xffu) - 127);
        for (const BvhChild& c : bvh_children(node)) {
            if (c.internal) continue;
            // The content's largest x and the triangle and vertex reaching it.
            double max_x = -1e300;
            uint32_t tri = 0;
            int vertex = 0;
            for (uint32_t k = 0; k < c.triangles; ++k) {
                const uint32_t t = bvh.leaf_indices[c.index + k];
                const vec3 v[3] = {tris[t].v0, tris[t].v1, tris[t].v2};
                for (int j = 0; j < 3; ++j)
                    if (v[j].x > max_x) max_x = v[j].x, tri = t, vertex = j;
            }
            CellRay cr;
            cr.node = n, cr.slot = c.slot;
            cr.q_short = uint32_t(std::ceil((max_x - p) / cell)) - 1u;  // below max_x
            const double inner = double(p) + double(cr.q_short) * cell;
            // A point of the triangle within the cell: near the vertex.
            const vec3 v[3] = {tris[tri].v0, tris[tri].v1, tris[tri].v2};
            const glm::dvec3 a(v[vertex]), b(v[(vertex + 1) % 3]), d3(v[(vertex + 2) % 3]);
            const double span = std::max(1e-30, std::max(a.x - b.x, a.x - d3.x));
            const double w = std::min(0.25, 0.25 * (max_x - inner) / span);
            const glm::dvec3 target = (1 - 2 * w) * a + w * b + w * d3;
            if (!(target.x > inner)) continue;
            const glm::dvec3 normal = glm::normalize(glm::cross(b - a, d3 - a));
            glm::dvec3 dir = glm::normalize(glm::dvec3(1.0, 0.37, -0.21));
            if (std::abs(glm::dot(dir, normal)) < 0.2) dir = glm::normalize(glm::dvec3(1.0, -0.6, 0.45));
            if (std::abs(glm::dot(dir, normal)) < 0.2) continue;
            // Back from the target until halfway to the inner plane.
            const double s = 0.5 * (target.x - inner) / dir.x;
            cr.ray.o = vec3(target - s * dir);
            cr.ray.d = vec3(dir);
            cr.ray.tmax = 3.0e38f;
            if (!(double(cr.ray.o.x) > inner)) continue;
            out.push_back(cr);
        }
    }
    return out;
}

// Negative control: leaf boxes one grid cell short of their triangles on x (no margin) miss
// the hits of rays that meet only that cell, which the checks above then report; the built
// tree, with its margin, finds every one.
TEST(WideBvhTraversal, BoxesOneCellShortAreCaught) {
    const std::vector<Triangle> tris = blob(10);
    const std::vector<gpu::GpuTriangle> g = device_triangles(tris);
    const KdTree bvh = build_kdtree(tris, bvh_options());
    const std::vector<CellRay> rays = last_cell_rays(bvh, tris);
    ASSERT_GT(rays.size(), 100u);
    KdTree planted = bvh;
    for (const CellRay& cr : rays) {
        gpu::BvhNode n = bvh_node(planted, cr.node);
        set_bvh_plane(n, 0, true, cr.slot, cr.q_short);
        set_bvh_node(planted, cr.node, n);
    }
    size_t caught = 0, hits = 0;
    for (const CellRay& cr : rays) {
        const gpu::Hit expected = brute_force_hit(g, cr.ray);
        if (expected.prim == NO_HIT) continue;
        ++hits;
        ASSERT_TRUE(same_hit(cpu_trace_tree(bvh, g, cr.ray), expected)) << "node " << cr.node;
        caught += !same_hit(cpu_trace_tree(planted, g, cr.ray), expected);
    }
    std::printf("last-cell rays: %zu hit, %zu of them wrong with boxes a cell short\n", hits, caught);
    EXPECT_GT(hits, 100u);
    EXPECT_GT(caught, hits / 2);
}

// Traversal work on a large mesh: few node visits and triangle tests per ray, and fewer
// bytes per triangle than the k-d tree.
TEST(WideBvhQuality, LittleWorkAndMemoryOnALargeMesh) {
    const std::vector<Triangle> tris = blob(64, 0.04f);  // 49,152 triangles
    const std::vector<gpu::GpuTriangle> g = device_triangles(tris);
    const KdTree bvh = build_kdtree(tris, bvh_options());
    const KdTree kd = build_kdtree(tris, TreeOptions{});
    // 224-byte nodes, about one per 10.4 triangles (the optimal collapse; 9.0 opening the
    // largest child first), and a 4-byte leaf index per triangle: 25.5 bytes a triangle here
    // (the k-d tree: 27.3). On the 871k dragon 24.9, which with the triangles' 40 is 64.9
    // against the k-d tree's 78.8 (docs/traversal.md).
    const double per_triangle = double(bvh.stats.bytes) / double(tris.size());
    EXPECT_LT(per_triangle, 32.0);
    EXPECT_LT(per_triangle, 1.1 * double(kd.stats.bytes) / double(tris.size()));
    gpu::RayWork work;
    for (const TestRay& r : test_rays(tris, 41)) work.add(cpu_trace_tree(bvh, g, device_ray(r)));
    std::printf("BVH: %.2f node visits, %.2f triangle tests per ray\n", work.visits_per_ray(),
                work.tests_per_ray());
    EXPECT_LT(work.visits_per_ray(), 12.0);
    EXPECT_LT(work.tests_per_ray(), 12.0);
}

// The SAH-optimal collapse against the largest child opened first, over the same binary
// tree: a lower SAH cost (each slot's box as quantized), fewer nodes, and no more work per ray
// (node visits at kSimtCostModel's two triangle tests each, as the collapse weighs them).
TEST(WideBvhQuality, OptimalCollapseCostsLessThanLargestChildFirst) {
    std::vector<NamedMesh> meshes = test_meshes();
    meshes.push_back({"blob(64)", blob(64, 0.04f)});
    const double node = kSimtCostModel.wide_node_visit;
    for (const NamedMesh& m : meshes) {
        const KdTree opt = build_kdtree(m.tris, bvh_options());
        const KdTree greedy = build_kdtree(m.tris, bvh_options(0, false));
        const double c_opt = bvh_sah_cost(opt, node, 1), c_greedy = bvh_sah_cost(greedy, node, 1);
        std::printf("%s: SAH cost %.3f against %.3f, %u against %u nodes\n", m.name.c_str(), c_opt,
                    c_greedy, bvh_node_count(opt), bvh_node_count(greedy));
        EXPECT_LE(c_opt, c_greedy) << m.name;
        EXPECT_LE(bvh_node_count(opt), bvh_node_count(greedy)) << m.name;
        const std::vector<gpu::GpuTriangle> g = device_triangles(m.tris);
        gpu::RayWork w_opt, w_greedy;
        for (const TestRay& r : test_rays(m.tris, 43)) {
            w_opt.add(cpu_trace_tree(opt, g, device_ray(r)));
            w_greedy.add(cpu_trace_tree(greedy, g, device_ray(r)));
        }
        const double work_opt = node * w_opt.node_visits + w_opt.tri_tests;
        const double work_greedy = node * w_greedy.node_visits + w_greedy.tri_tests;
        std::printf("  work per ray %.2f against %.2f\n", work_opt / w_opt.rays,
                    work_greedy / w_greedy.rays);
        EXPECT_LE(work_opt, work_greedy) << m.name;
    }
}

// The optimal collapse at every scale: the blob scaled by 2^-60 and 2^60 (exact in float)
// and moved far from the origin by a power of two gives the same tree (its leaves in the same
// order, as many nodes), its costs never overflowing.
TEST(WideBvhQuality, OptimalCollapseTheSameAtEveryScale) {
    const auto moved = [](float shift, float scale) {
        std::vector<Triangle> tris = blob(24);
        for (Triangle& t : tris)
            for (vec3* v : {&t.v0, &t.v1, &t.v2}) *v = (*v + shift) * scale;
        return tris;
    };
    for (const float shift : {0.f, 0x1p4f}) {
        const KdTree unit = build_kdtree(moved(shift, 1.f), bvh_options());
        for (const float scale : {0x1p-60f, 0x1p60f}) {
            const KdTree bvh = build_kdtree(moved(shift, scale), bvh_options());
            EXPECT_EQ(bvh_node_count(bvh), bvh_node_count(unit)) << scale << ", " << shift;
            EXPECT_EQ(bvh.leaf_indices, unit.leaf_indices) << scale << ", " << shift;
        }
    }
}

// The parallel build (subtrees from 16,384 references on threads) on the large mesh: its
// closest hits are brute force's, bit for bit.
TEST(WideBvhTraversal, LargeMeshHitsAreBruteForces) {
    const std::vector<Triangle> tris = blob(64, 0.04f);  // 49,152 triangles
    const std::vector<gpu::GpuTriangle> g = device_triangles(tris);
    const KdTree bvh = build_kdtree(tris, bvh_options());
    size_t hits = 0;
    for (const TestRay& r : test_rays(tris, 41)) {
        const gpu::Ray ray = device_ray(r);
        const gpu::Hit expected = brute_force_hit(g, ray);
        ASSERT_TRUE(same_hit(cpu_trace_tree(bvh, g, ray), expected)) << describe_ray(r);
        hits += expected.prim != NO_HIT;
    }
    EXPECT_GT(hits, 100u);
}

// Child order: two walls across one axis, a ray along it (in each of the 8 octants, the other
// components small): the nearer wall's subtree is visited first, so the farther one, entered
// beyond the hit, never has a triangle tested. The oracle: the same ray cut short of the far
// wall (tmax) tests exactly as many triangles. A flipped octant bit tests the far wall first.
TEST(WideBvhTraversal, NearestChildFirstInEveryOctant) {
    // A 4x4 grid of quads (32 triangles) across `axis` at `at`, spanning [-1, 1] on the others.
    const auto wall = [](int axis, float at, std::vector<Triangle>& out) {
        const int u = (axis + 1) % 3, v = (axis + 2) % 3;
        for (int i = 0; i < 4; ++i)
            for (int j = 0; j < 4; ++j) {
                vec3 p[4];
                for (int k = 0; k < 4; ++k) {
                    p[k][axis] = at;
                    p[k][u] = -1.f + 0.5f * float(i + (k == 1 || k == 2));
                    p[k][v] = -1.f + 0.5f * float(j + (k >= 2));
                }
                out.push_back({p[0], p[1], p[2]});
                out.push_back({p[0], p[2], p[3]});
            }
    };
    for (int axis = 0; axis < 3; ++axis)
        for (int octant = 0; octant < 8; ++octant) {
            const vec3 sign((octant & 1) ? -1.f : 1.f, (octant & 2) ? -1.f : 1.f,
                            (octant & 4) ? -1.f : 1.f);
            std::vector<Triangle> tris;
            wall(axis, 2.f * sign[axis], tris);
            wall(axis, 6.f * sign[axis], tris);
            const std::vector<gpu::GpuTriangle> g = device_triangles(tris);
            // (Largest child first: each wall a node of its own, which the traversal orders
            // by octant. The optimal collapse packs both walls' leaves into shared nodes, whose
            // triangles are tested in offset order.)
            const KdTree bvh = build_kdtree(tris, bvh_options(0, false));
            vec3 d = 0.05f * sign;
            d[axis] = sign[axis];
            d = glm::normalize(d);
            for (int k = 0; k < 9; ++k) {
                gpu::Ray ray;
                ray.o = vec3(0.f);
                ray.o[(axis + 1) % 3] = -0.4f + 0.1f * float(k);
                ray.o[(axis + 2) % 3] = 0.3f - 0.07f * float(k);
                ray.d = d, ray.tmax = 3.0e38f;
                const gpu::Hit full = cpu_trace_tree(bvh, g, ray);
                ASSERT_NE(full.prim, NO_HIT);
                ASSERT_LT(full.prim, 32u) << "the near wall is hit first";
                gpu::Ray cut = ray;
                cut.tmax = 4.f / std::abs(d[axis]);  // between the walls
                const gpu::Hit near = cpu_trace_tree(bvh, g, cut);
                ASSERT_TRUE(same_hit(full, near));
                // (Node visits may differ: the far wall's node, pushed while its box was met,
                // is popped and its children's boxes tested against the hit's distance.)
                EXPECT_EQ(full.tri_tests, near.tri_tests)
                    << "axis " << axis << ", octant " << octant << ", ray " << k;
            }
        }
}

// The model of a GPU warp that `mcpt tree` prints (issue 64's probe): each lane's log of node
// visits is what the path's counter adds up, and the warp's figures are the work over the
// longest ray of each trace, worked by hand.
TEST(WarpModel, LanesAreTheWorkOverEachTracesLongestRay) {
    // Trace 0: lanes visit 1 and 3 nodes (a third lane's path traced nothing): the warp waits
    // 3 steps, 2 lanes tracing; trace 1: 1 node, 1 lane tracing. 5 visits over 4 steps.
    const WarpLanes w = warp_lanes({{1, 1}, {3}, {}});
    EXPECT_DOUBLE_EQ(w.busy, 5.0 / 4.0);
    EXPECT_DOUBLE_EQ(w.active, (3.0 * 2 + 1.0 * 1) / 4.0);
    const WarpLanes same = warp_lanes(std::vector<std::vector<uint32_t>>(32, {2, 5, 1}));
    EXPECT_DOUBLE_EQ(same.busy, 32.0);
    EXPECT_DOUBLE_EQ(same.active, 32.0);
    EXPECT_DOUBLE_EQ(warp_lanes({}).busy, 0.0);

    Scene scene = make_bumpy_sphere_scene(20);
    validate_scene(scene);
    const GpuScene g = pack_scene(scene, build_kdtree(scene.triangles, bvh_options()));
    gpu::GpuParams p = g.params;
    set_camera(p, scene.camera, 64, 64);
    p.max_depth = 8, p.rr_depth = 3, p.seed = 7;
    double rays = 0;
    for (uint32_t pixel = 0; pixel < 4096; pixel += 97) {
        const gpu::RayWork work = cpu_path_work(g, p, pixel, 3);
        const std::vector<uint32_t> visits = cpu_path_visits(g, p, pixel, 3);
        ASSERT_EQ(double(visits.size()), work.rays) << pixel;
        double sum = 0;
        for (uint32_t v : visits) sum += v;
        EXPECT_EQ(sum, work.node_visits) << pixel;
        rays += work.rays;
    }
    EXPECT_GT(rays, 2 * 43.0);  // paths of more than a camera ray
}

// The walk's model (step_slot_walk) against lock-step, worked by hand on two lanes whose rays
// take 3 then 1 node steps and 1 then 1, shading costing 2 steps.
TEST(WarpModel, WalkedCostAgainstLockStep) {
    const std::vector<std::vector<uint32_t>> lanes = {{3, 1}, {1, 1}};
    // Lock-step: (3 + 2) + (1 + 2).
    EXPECT_DOUBLE_EQ(lockstep_cost(lanes, 2), 8.0);
    // One step a pause: lane 1 shades after each step, lane 0 walks on: 4 steps and 4
    // shadings (its first ray: 3 steps under 2 shadings, then one of its own; its second: 1).
    EXPECT_DOUBLE_EQ(walked_cost(lanes, 2, 1), 12.0);
    // Pauses no shorter than the longest ray: lock-step.
    EXPECT_DOUBLE_EQ(walked_cost(lanes, 2, 4), 8.0);
    // A vote for both lanes: walk until both rays ended, then shade.
    EXPECT_DOUBLE_EQ(walked_cost(lanes, 2, 2, true), 8.0);
    // The walk's gain: each lane's long ray at another place in its stream holds every
    // lock-step iteration (4 x (8 + 2)); walked 2 steps at a time, each lane takes 4 + 3
    // pauses of 2 + 2, side by side.
    const std::vector<std::vector<uint32_t>> skewed = {
        {8, 1, 1, 1}, {1, 8, 1, 1}, {1, 1, 8, 1}, {1, 1, 1, 8}};
    EXPECT_DOUBLE_EQ(lockstep_cost(skewed, 2), 40.0);
    EXPECT_DOUBLE_EQ(walked_cost(skewed, 2, 2), 28.0);
}

// The work-group's model, worked by hand: warps of two lanes, [A, B] and [C, D]; A and C trace
// one ray of 3 node steps, B and D three of 1; a pause each step, shading costing 2.
TEST(WarpModel, RegroupedWorkGroupAgainstKeptWarps) {
    const std::vector<std::vector<uint32_t>> lanes = {{3}, {1, 1, 1}, {3}, {1, 1, 1}};
    // Kept: each pause both warps walk a step and both shade (B, D): 3 x (2 + 4).
    EXPECT_DOUBLE_EQ(grouped_walk_cost(lanes, 2, 1, false, 0, 2), 18.0);
    // Regrouped: B and D share the first warp, so one warp shades in the first two pauses;
    // in the third every lane ends and both shade: (2 + 2) + (2 + 2) + (2 + 4).
    EXPECT_DOUBLE_EQ(grouped_walk_cost(lanes, 2, 1, true, 0, 2), 14.0);
    // The exchange at 1 node step a warp, each of the three pauses: 14 + 3 x 2.
    EXPECT_DOUBLE_EQ(grouped_walk_cost(lanes, 2, 1, true, 1, 2), 20.0);
    // One warp holding every lane: regrouping changes nothing.
    EXPECT_DOUBLE_EQ(grouped_walk_cost(lanes, 2, 1, true, 0, 4),
                     grouped_walk_cost(lanes, 2, 1, false, 0, 4));
}

}  // namespace
}  // namespace mcpt
