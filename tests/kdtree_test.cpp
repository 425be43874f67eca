// Tests of the k-d tree builder (common/kdtree.h): names and options, the flattened layout
// and its statistics, point coverage, determinism across thread counts, and closest hits
// through the tree against brute force over all triangles, for every kind and several depths.
// Two traversals are checked: a plain pbrt-v3 KdTreeAccel::Intersect written here (double
// precision, a stack of exactly stack_size() entries) and the shared device traversal
// gpu::trace_ray from common/gpu/traverse.h.
#include "common/accel/kdtree.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <iterator>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "common/accel/cpu_trace.h"
#include "common/error.h"
#include "common/gpu/traverse.h"
#include "accel_cases.h"

namespace mcpt {
namespace {

using glm::dvec3;
using glm::vec3;

constexpr double kInf = std::numeric_limits<double>::infinity();


// ---------------------------------------------------------------- reference traversal

struct TestHit {
    double t = kInf;
    uint32_t tri = ~0u;
    size_t tests = 0;
    bool overflow = false;
    bool hit() const { return tri != ~0u; }
};

// Möller-Trumbore in double: the hit distance if positive, else kInf.
double intersect(const Triangle& tri, const dvec3& o, const dvec3& d) {
    const dvec3 v0(tri.v0), e1 = dvec3(tri.v1) - v0, e2 = dvec3(tri.v2) - v0;
    const dvec3 p = glm::cross(d, e2);
    const double det = glm::dot(e1, p);
    if (det == 0.0) return kInf;
    const double inv = 1.0 / det;
    const dvec3 s = o - v0;
    const double u = glm::dot(s, p) * inv;
    if (u < 0.0 || u > 1.0) return kInf;
    const dvec3 q = glm::cross(s, e1);
    const double v = glm::dot(d, q) * inv;
    if (v < 0.0 || u + v > 1.0) return kInf;
    const double t = glm::dot(e2, q) * inv;
    return t > 0.0 ? t : kInf;
}

// Closest hit; among equal distances the lowest triangle index wins.
void consider(const std::vector<Triangle>& tris, uint32_t index, const dvec3& o, const dvec3& d,
              TestHit& hit) {
    ++hit.tests;
    const double t = intersect(tris[index], o, d);
    if (t < hit.t || (t == hit.t && t < kInf && index < hit.tri)) hit.t = t, hit.tri = index;
}

TestHit brute_force(const std::vector<Triangle>& tris, const TestRay& ray) {
    TestHit hit;
    for (uint32_t i = 0; i < tris.size(); ++i) consider(tris, i, dvec3(ray.o), dvec3(ray.d), hit);
    return hit;
}

// pbrt-v3 KdTreeAccel::Intersect over the flattened nodes, over t in [0, inf), with a small
// relative slack on the split distances and a stack of exactly stack_size() entries. A ray
// lying in a split plane visits both children over its whole interval, so deferred nodes are
// not sorted by distance: one beyond the hit is skipped, not taken as the end of the walk.
TestHit trace_tree(const KdTree& tree, const std::vector<Triangle>& tris, const TestRay& ray) {
    constexpr double kSlack = 1e-9;
    const dvec3 o(ray.o), d(ray.d);
    struct Todo {
        uint32_t node;
        double tmin, tmax;
    };
    std::vector<Todo> todo(tree.stack_size());
    size_t todo_pos = 0;
    TestHit hit;
    uint32_t node = 0;
    double tmin = 0.0, tmax = kInf;
    while (true) {
        const gpu::KdNode& n = tree.nodes[node];
        const uint32_t axis = n.flags & 3u;
        if (axis != KD_LEAF) {
            // Interior: visit the children in ray order.
            float split;
            std::memcpy(&split, &n.split_or_offset, 4);
            const double oa = o[int(axis)], da = d[int(axis)];
            const bool below_first = oa < split || (oa == split && da <= 0.0);
            const uint32_t first = below_first ? node + 1 : n.flags >> 2;
            const uint32_t second = below_first ? n.flags >> 2 : node + 1;
            const bool in_plane = da == 0.0 && oa == split;
            const double t_plane = da == 0.0 ? kInf : (split - oa) / da;
            if (!in_plane && (t_plane > tmax * (1 + kSlack) || t_plane <= 0.0)) {
                node = first;
            } else if (!in_plane && t_plane < tmin * (1 - kSlack)) {
                node = second;
            } else {
                if (todo_pos == todo.size()) {
                    hit.overflow = true;
                    return hit;
                }
                todo[todo_pos++] = {second, in_plane ? tmin : t_plane * (1 - kSlack), tmax};
                node = first;
                if (!in_plane) tmax = t_plane * (1 + kSlack);
            }
            continue;
        }
        // Leaf: its triangles, then the next deferred node that starts before the hit.
        for (uint32_t i = 0; i < (n.flags >> 2); ++i) {
            consider(tris, tree.leaf_indices[n.split_or_offset + i], o, d, hit);
        }
        do {
            if (todo_pos == 0) return hit;
            const Todo& next = todo[--todo_pos];
            node = next.node, tmin = next.tmin, tmax = next.tmax;
        } while (hit.t < tmin);
    }
}

// ---------------------------------------------------------------- structure

float split_of(const gpu::KdNode& n) {
    float f;
    std::memcpy(&f, &n.split_or_offset, 4);
    return f;
}

struct Walk {
    size_t visited = 0, leaves = 0, empty_leaves = 0, references = 0;
    int max_depth = 0;
    std::vector<int> ref_count;  // leaves referencing each triangle
};

// Walks the tree, checking links and ranges on the way.
Walk check_structure(const KdTree& tree, size_t triangle_count, const std::string& what) {
    Walk w;
    w.ref_count.assign(triangle_count, 0);
    std::vector<std::pair<uint32_t, int>> stack{{0u, 0}};
    std::vector<char> seen(tree.nodes.size(), 0);
    while (!stack.empty()) {
        const auto [index, depth] = stack.back();
        stack.pop_back();
        EXPECT_FALSE(seen[index]) << what << ": node " << index << " reached twice";
        if (seen[index]) return w;
        seen[index] = 1;
        ++w.visited;
        const gpu::KdNode& n = tree.nodes[index];
        if ((n.flags & 3u) == KD_LEAF) {
            const uint32_t count = n.flags >> 2, first = n.split_or_offset;
            EXPECT_LE(size_t(first) + count, tree.leaf_indices.size()) << what;
            if (size_t(first) + count > tree.leaf_indices.size()) return w;
            ++w.leaves;
            w.empty_leaves += count == 0;
            w.references += count;
            w.max_depth = std::max(w.max_depth, depth);
            for (uint32_t i = first; i < first + count; ++i) {
                EXPECT_LT(tree.leaf_indices[i], triangle_count) << what;
                if (tree.leaf_indices[i] < triangle_count) ++w.ref_count[tree.leaf_indices[i]];
            }
        } else {
            const uint32_t above = n.flags >> 2;
            EXPECT_TRUE(std::isfinite(split_of(n))) << what;
            EXPECT_GT(above, index + 1) << what << ": above child must follow the below subtree";
            EXPECT_LT(above, tree.nodes.size()) << what;
            EXPECT_LT(index + 1, tree.nodes.size()) << what;
            if (above <= index + 1 || above >= tree.nodes.size()) return w;
            stack.push_back({above, depth + 1});
            stack.push_back({index + 1, depth + 1});
        }
    }
    EXPECT_EQ(w.visited, tree.nodes.size()) << what << ": unreachable nodes";
    return w;
}

void check_stats(const KdTree& tree, const Walk& w, size_t triangle_count,
                 const std::string& what) {
    const TreeStats& s = tree.stats;
    EXPECT_EQ(s.nodes, tree.nodes.size()) << what;
    EXPECT_EQ(s.references, tree.leaf_indices.size()) << what;
    EXPECT_EQ(s.references, w.references) << what << ": leaf index array has unused entries";
    EXPECT_EQ(s.leaves, w.leaves) << what;
    EXPECT_EQ(s.empty_leaves, w.empty_leaves) << what;
    EXPECT_EQ(s.max_depth, w.max_depth) << what;
    EXPECT_EQ(s.nodes, 2 * s.leaves - 1) << what;
    EXPECT_EQ(s.bytes, s.nodes * 8 + s.references * 4) << what;
    EXPECT_GE(s.build_seconds, 0.0) << what;
    const size_t full = s.leaves - s.empty_leaves;
    EXPECT_DOUBLE_EQ(s.mean_leaf_size, full ? double(s.references) / double(full) : 0.0) << what;
    EXPECT_EQ(tree.stack_size(), uint32_t(s.max_depth) + 1) << what;
    for (size_t i = 0; i < triangle_count; ++i) {
        EXPECT_GE(w.ref_count[i], 1) << what << ": triangle " << i << " in no leaf";
        if (w.ref_count[i] < 1) break;
    }
}

// True when some leaf reached by descending to point p (either side on a tie) lists `tri`.
bool covers(const KdTree& tree, uint32_t node, const vec3& p, uint32_t tri) {
    const gpu::KdNode& n = tree.nodes[node];
    const uint32_t axis = n.flags & 3u;
    if (axis == KD_LEAF) {
        const uint32_t* first = &tree.leaf_indices[0] + n.split_or_offset;
        return std::find(first, first + (n.flags >> 2), tri) != first + (n.flags >> 2);
    }
    const float split = split_of(n), x = p[int(axis)];
    if (x < split) return covers(tree, node + 1, p, tri);
    if (x > split) return covers(tree, n.flags >> 2, p, tri);
    return covers(tree, node + 1, p, tri) || covers(tree, n.flags >> 2, p, tri);
}

// Points on each triangle (vertices, edge midpoints, inner points) lie in a leaf listing it.
void check_coverage(const KdTree& tree, const std::vector<Triangle>& tris,
                    const std::string& what) {
    const double bary[][3] = {
        {1, 0, 0},   {0, 1, 0},    {0, 0, 1},    {.5, .5, 0},  {0, .5, .5},
        {.5, 0, .5}, {.2, .3, .5}, {.7, .2, .1}, {.1, .1, .8}, {1. / 3, 1. / 3, 1. / 3}};
    for (uint32_t i = 0; i < tris.size(); ++i) {
        const Triangle& t = tris[i];
        const vec3 lo = glm::min(t.v0, glm::min(t.v1, t.v2));
        const vec3 hi = glm::max(t.v0, glm::max(t.v1, t.v2));
        for (const auto& b : bary) {
            const dvec3 q = b[0] * dvec3(t.v0) + b[1] * dvec3(t.v1) + b[2] * dvec3(t.v2);
            const vec3 p = glm::clamp(vec3(q), lo, hi);
            if (!covers(tree, 0, p, i)) {
                ADD_FAILURE() << what << ": point (" << p.x << ", " << p.y << ", " << p.z
                              << ") of triangle " << i << " not in its leaf";
                return;
            }
        }
    }
}

// ---------------------------------------------------------------- helpers

TreeOptions options(TreeKind kind, int depth, int threads = 0) {
    TreeOptions o;
    o.kind = kind;
    o.max_depth = depth;
    o.threads = threads;
    return o;
}

std::string label(const std::string& mesh, TreeKind kind, int depth) {
    return mesh + "/" + tree_kind_name(kind) + "/depth " + std::to_string(depth);
}

// Depths tried per kind; the median tree duplicates stacked triangles 2^depth times (the BVH
// has no depth option).
std::vector<int> depths_for(TreeKind kind) {
    if (kind == TreeKind::None || kind == TreeKind::Bvh) return {-1};
    if (kind == TreeKind::Median) return {-1, 0, 1, 5, 8};
    return {-1, 0, 1, 4, 12, 40};
}


// Every test mesh, each kind and depth of tree (the BVH too: the device traversal's checks
// hold for it), and rays from test_rays(mesh, seed) as device rays: check(label, device
// triangles, tree, ray, device ray); stops at the first fatal failure.
template <class Check>
void for_each_device_ray(uint32_t seed, Check check) {
    for (const NamedMesh& m : test_meshes()) {
        const std::vector<gpu::GpuTriangle> g = device_triangles(m.tris);
        const std::vector<TestRay> rays = test_rays(m.tris, seed);
        for (TreeKind kind : {TreeKind::Sah, TreeKind::Median, TreeKind::None, TreeKind::Bvh}) {
            for (int depth : depths_for(kind)) {
                const std::string what = label(m.name, kind, depth);
                const KdTree tree = build_kdtree(m.tris, options(kind, depth));
                for (const TestRay& r : rays) {
                    gpu::Ray ray;
                    ray.o = r.o, ray.d = r.d, ray.tmax = 3.0e38f;
                    check(what, g, tree, r, ray);
                    if (testing::Test::HasFatalFailure()) return;
                }
            }
        }
    }
}

// Same hit or miss, same distance; the same triangle unless another one ties at that distance
// (a ray through a shared edge or vertex).
void compare_hits(const TestHit& expect, const TestHit& got, const TestRay& r,
                  const std::string& what) {
    ASSERT_FALSE(got.overflow) << what << ": traversal stack of stack_size() overflowed";
    ASSERT_EQ(expect.hit(), got.hit())
        << what << ": " << describe_ray(r) << ", expected triangle " << expect.tri << " at "
        << expect.t << ", got " << got.tri << " at " << got.t;
    if (!expect.hit()) return;
    ASSERT_NEAR(got.t, expect.t, 1e-9 * expect.t)
        << what << ": " << describe_ray(r) << ", triangle " << got.tri << " instead of "
        << expect.tri;
}

// ---------------------------------------------------------------- tests

TEST(KdTreeNames, ParseAndName) {
    for (TreeKind k : {TreeKind::Sah, TreeKind::Median, TreeKind::None, TreeKind::Bvh}) {
        EXPECT_EQ(parse_tree_kind(tree_kind_name(k)), k);
    }
    EXPECT_STREQ(tree_kind_name(TreeKind::Sah), "sah");
    EXPECT_STREQ(tree_kind_name(TreeKind::Median), "median");
    EXPECT_STREQ(tree_kind_name(TreeKind::None), "none");
    try {
        parse_tree_kind("octree");
        FAIL() << "unknown kind accepted";
    } catch (const Error& e) {
        const std::string msg = e.what();
        EXPECT_NE(msg.find("octree"), std::string::npos) << msg;
        for (const char* valid : {"sah", "median", "none", "bvh"}) {
            EXPECT_NE(msg.find(valid), std::string::npos) << msg;
        }
    }
    EXPECT_THROW(parse_tree_kind("SAH "), Error);
    EXPECT_THROW(parse_tree_kind(""), Error);
}

TEST(KdTreeOptions, RejectsBadDepth) {
    const std::vector<Triangle> tris = random_soup(10, 2);
    EXPECT_THROW(build_kdtree(tris, options(TreeKind::Sah, -2)), Error);
    EXPECT_THROW(build_kdtree(tris, options(TreeKind::Median, 1000)), Error);
}

TEST(KdTreeBuild, EmptyInputGivesOneEmptyLeaf) {
    for (TreeKind kind : {TreeKind::Sah, TreeKind::Median, TreeKind::None}) {
        const KdTree tree = build_kdtree({}, options(kind, -1));
        ASSERT_EQ(tree.nodes.size(), 1u) << tree_kind_name(kind);
        EXPECT_EQ(tree.nodes[0].flags, KD_LEAF);
        EXPECT_TRUE(tree.leaf_indices.empty());
        EXPECT_TRUE(tree.bounds.empty());
        EXPECT_EQ(tree.stats.leaves, 1u);
        EXPECT_EQ(tree.stats.empty_leaves, 1u);
        EXPECT_EQ(tree.stats.max_depth, 0);
        EXPECT_EQ(tree.stats.mean_leaf_size, 0.0);
        EXPECT_EQ(tree.stack_size(), 1u);
        EXPECT_FALSE(trace_tree(tree, {}, {{0, 0, 0}, {0, 0, 1}}).hit());
    }
}

TEST(KdTreeBuild, NoneIsOneLeafWithEveryTriangle) {
    const std::vector<Triangle> tris = random_soup(50, 3);
    const KdTree tree = build_kdtree(tris, options(TreeKind::None, 7));
    ASSERT_EQ(tree.nodes.size(), 1u);
    EXPECT_EQ(tree.nodes[0].split_or_offset, 0u);
    EXPECT_EQ(tree.nodes[0].flags, (50u << 2) | KD_LEAF);
    ASSERT_EQ(tree.leaf_indices.size(), 50u);
    for (uint32_t i = 0; i < 50; ++i) EXPECT_EQ(tree.leaf_indices[i], i);
    EXPECT_EQ(tree.stats.max_depth, 0);
    EXPECT_DOUBLE_EQ(tree.stats.mean_leaf_size, 50.0);
}

TEST(KdTreeBuild, StructureAndStatsForEveryKindAndDepth) {
    for (const NamedMesh& m : test_meshes()) {
        for (TreeKind kind : {TreeKind::Sah, TreeKind::Median, TreeKind::None}) {
            for (int depth : depths_for(kind)) {
                const std::string what = label(m.name, kind, depth);
                const KdTree tree = build_kdtree(m.tris, options(kind, depth));
                const Walk w = check_structure(tree, m.tris.size(), what);
                check_stats(tree, w, m.tris.size(), what);
                check_coverage(tree, m.tris, what);
                // Depth limits.
                const int sah_default =
                    int(std::lround(8 + 1.3 * std::log2(double(m.tris.size()))));
                const int limit = kind == TreeKind::None     ? 0
                                  : depth >= 0               ? depth
                                  : kind == TreeKind::Median ? 3
                                                             : sah_default;
                EXPECT_LE(tree.stats.max_depth, limit) << what;
                EXPECT_FALSE(describe(tree.stats, m.tris.size()).empty());
            }
        }
    }
}

TEST(KdTreeBuild, MedianSplitsToExactlyMaxDepth) {
    const std::vector<Triangle> tris = blob(10);
    for (int depth : {-1, 0, 2, 7}) {
        const KdTree tree = build_kdtree(tris, options(TreeKind::Median, depth));
        const int want = depth < 0 ? 3 : depth;
        EXPECT_EQ(tree.stats.max_depth, want);
        // Every leaf above the last level holds at most one triangle; axes cycle x, y, z.
        std::vector<std::pair<uint32_t, int>> stack{{0u, 0}};
        while (!stack.empty()) {
            const auto [index, d] = stack.back();
            stack.pop_back();
            const gpu::KdNode& n = tree.nodes[index];
            if ((n.flags & 3u) == KD_LEAF) {
                if (d < want) {
                    EXPECT_LE(n.flags >> 2, 1u) << "leaf at depth " << d;
                }
            } else {
                EXPECT_EQ(int(n.flags & 3u), d % 3);
                stack.push_back({n.flags >> 2, d + 1});
                stack.push_back({index + 1, d + 1});
            }
        }
    }
    // The root splits at the median centroid: half the centroids on either side.
    const KdTree tree = build_kdtree(tris, options(TreeKind::Median, 1));
    const float split = split_of(tree.nodes[0]);
    size_t below = 0, above = 0;
    for (const Triangle& t : tris) {
        const float c = (t.v0.x + t.v1.x + t.v2.x) * (1.f / 3.f);
        below += c<split, above += c> split;
    }
    EXPECT_LE(below, tris.size() / 2);
    EXPECT_LE(above, tris.size() / 2);
}

// Touching the plane puts a triangle on the side it overlaps; lying in it, on both sides.
TEST(KdTreeBuild, MedianSidesOfTouchingAndInPlaneTriangles) {
    const std::vector<Triangle> tris = {
        tri({0, 0, 0}, {1, 0, 0}, {0, 1, 1}),        // x in [0, 1]: touches x = 1 from below
        tri({1, 0, 0}, {1, 1, 0}, {1, 0, 1}),        // lies in x = 1
        tri({1, 0, 0}, {2, 1, 0}, {2, 0, 1}),        // x in [1, 2]: touches from above
        tri({0.5f, 0, 0}, {1.5f, 1, 0}, {1, 0, 1}),  // crosses x = 1
    };
    const KdTree tree = build_kdtree(tris, options(TreeKind::Median, 1));
    ASSERT_EQ(tree.nodes.size(), 3u);
    EXPECT_EQ(tree.nodes[0].flags, (2u << 2) | 0u);
    EXPECT_EQ(split_of(tree.nodes[0]), 1.f);  // centroids 1/3, 1, 5/3, 1: median 1
    const auto leaf = [&](uint32_t i) {
        const gpu::KdNode& n = tree.nodes[i];
        std::vector<uint32_t> v(tree.leaf_indices.begin() + n.split_or_offset,
                                tree.leaf_indices.begin() + n.split_or_offset + (n.flags >> 2));
        std::sort(v.begin(), v.end());
        return v;
    };
    EXPECT_EQ(leaf(1), (std::vector<uint32_t>{0, 1, 3}));
    EXPECT_EQ(leaf(2), (std::vector<uint32_t>{1, 2, 3}));
}

TEST(KdTreeBuild, StackedTrianglesStopAtTheDepthLimit) {
    const std::vector<Triangle> tris = stacked(1000);
    for (TreeKind kind : {TreeKind::Sah, TreeKind::Median}) {
        for (int depth : {-1, 3, 6}) {
            const KdTree tree = build_kdtree(tris, options(kind, depth));
            const int limit = depth >= 0 ? depth
                                         : (kind == TreeKind::Median
                                                ? 3
                                                : int(std::lround(8 + 1.3 * std::log2(1000.0))));
            EXPECT_LE(tree.stats.max_depth, limit);
            if (kind == TreeKind::Median) {
                EXPECT_EQ(tree.stats.max_depth, limit);
            }
            // Every leaf still holds all of them: no split can separate identical triangles.
            for (const gpu::KdNode& n : tree.nodes) {
                if ((n.flags & 3u) == KD_LEAF && (n.flags >> 2) != 0) {
                    EXPECT_EQ(n.flags >> 2, 1000u);
                }
            }
        }
    }
}

TEST(KdTreeBuild, FlatMeshSplitsOnlyInItsPlane) {
    const std::vector<Triangle> tris = flat_grid(16);
    const KdTree tree = build_kdtree(tris, options(TreeKind::Sah, -1));
    EXPECT_GT(tree.stats.leaves, 16u);
    for (const gpu::KdNode& n : tree.nodes) {
        if ((n.flags & 3u) != KD_LEAF) {
            EXPECT_NE(n.flags & 3u, 2u) << "split across z = 0.5";
        }
    }
}

// A node whose references span less than 64 / FLT_MAX along an axis (1e-38 here) made the
// binned SAH's scale overflow to inf and convert inf to a bin index (UBSan; on x86 a write far
// before the bin counts). Found by the glTF fuzz target (regressions/gltf/sah_bins_thin_union.glb).
TEST(KdTreeBuild, BinnedSahOverADenormalThinUnion) {
    std::vector<Triangle> tris;
    for (int i = 0; i < 64; ++i) {
        const float x = float(i % 8), y = float(i / 8), z = (i & 1) ? 1e-38f : 0.f;
        tris.push_back({{x, y, z}, {x + 1.f, y, 0.f}, {x, y + 1.f, z}, 0});
    }
    const KdTree tree = build_kdtree(tris, options(TreeKind::Sah, -1));
    EXPECT_GT(tree.stats.leaves, 8u);
    size_t references = 0;
    for (const gpu::KdNode& n : tree.nodes)
        if ((n.flags & 3u) == KD_LEAF) references += n.flags >> 2;
    EXPECT_EQ(references, tree.leaf_indices.size());
    for (uint32_t index : tree.leaf_indices) EXPECT_LT(index, tris.size());
}

// Triangles with NaN corners compared false against every split plane, so every split
// copied them to both sides: 38 triangles grew 10.8 million references in 0.6 s (a fuzzing
// timeout under the sanitizers; tests/fuzz/regressions/kdtree/nan_triangles_38). Non-finite
// triangles now stay out of the tree (they cannot be hit; scenes refuse them earlier).
TEST(KdTreeBuild, NonFiniteTrianglesStayOutOfTheTree) {
    std::ifstream in(
        std::string(MCPT_TEST_DATA_DIR) + "/../fuzz/regressions/kdtree/nan_triangles_38",
        std::ios::binary);
    const std::vector<char> bytes{std::istreambuf_iterator<char>(in), {}};
    ASSERT_GT(bytes.size(), 4u + 36u * 38u);
    std::vector<Triangle> tris(38);
    for (size_t i = 0; i < tris.size(); ++i) {
        float v[9];
        std::memcpy(v, bytes.data() + 4 + 36 * i, sizeof v);
        tris[i] = {{v[0], v[1], v[2]}, {v[3], v[4], v[5]}, {v[6], v[7], v[8]}, 0};
    }
    const KdTree tree = build_kdtree(tris, options(TreeKind::Sah, 31));
    EXPECT_LT(tree.leaf_indices.size(), 100000u) << describe(tree.stats, tris.size());
    for (uint32_t index : tree.leaf_indices) {
        const Triangle& t = tris[index];
        for (const glm::vec3& v : {t.v0, t.v1, t.v2})
            EXPECT_TRUE(std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z)) << index;
    }
}

TEST(KdTreeBuild, SameTreeForEveryThreadCount) {
    const std::vector<Triangle> tris = blob(40);  // 19200 triangles: subtrees go to workers
    for (TreeKind kind : {TreeKind::Sah, TreeKind::Median}) {
        const KdTree one = build_kdtree(tris, options(kind, kind == TreeKind::Sah ? -1 : 12, 1));
        for (int threads : {2, 3, 8}) {
            const KdTree many =
                build_kdtree(tris, options(kind, kind == TreeKind::Sah ? -1 : 12, threads));
            ASSERT_EQ(many.nodes.size(), one.nodes.size()) << threads << " threads";
            EXPECT_EQ(std::memcmp(many.nodes.data(), one.nodes.data(), one.nodes.size() * 8), 0)
                << threads << " threads";
            EXPECT_EQ(many.leaf_indices, one.leaf_indices) << threads << " threads";
        }
    }
}

TEST(KdTreeTraversal, MatchesBruteForce) {
    for (const NamedMesh& m : test_meshes()) {
        const std::vector<TestRay> rays = test_rays(m.tris, 11);
        std::vector<TestHit> expected;
        for (const TestRay& r : rays) expected.push_back(brute_force(m.tris, r));
        for (TreeKind kind : {TreeKind::Sah, TreeKind::Median, TreeKind::None}) {
            for (int depth : depths_for(kind)) {
                const std::string what = label(m.name, kind, depth);
                const KdTree tree = build_kdtree(m.tris, options(kind, depth));
                for (size_t i = 0; i < rays.size(); ++i) {
                    compare_hits(expected[i], trace_tree(tree, m.tris, rays[i]), rays[i], what);
                    if (testing::Test::HasFatalFailure()) return;
                }
            }
        }
    }
}

// The shared device traversal (gpu::trace_ray on the CPU) on the same trees. Rays lying in a
// split plane (stairs faces, the blob's vertex rows) make the traversal defer the far child
// with the near child's tmin, so deferred nodes are not sorted by distance there: a traversal
// that stops at the first one starting beyond the hit misses triangles touching the plane
// from that side (it did, on stairs/sah).
TEST(KdTreeTraversal, DeviceTraversalMatchesBruteForce) {
    for_each_device_ray(12, [](const std::string& what, const std::vector<gpu::GpuTriangle>& g,
                               const KdTree& tree, const TestRay& r, const gpu::Ray& ray) {
        ASSERT_LE(tree.stack_size(), KD_STACK_SIZE) << what;
        // Brute force with the same triangle test.
        const gpu::Hit b = brute_force_hit(g, ray);
        const float best = b.t;
        const uint32_t best_tri = b.prim;
        const gpu::Hit h = cpu_trace_tree(tree, g, ray);
        ASSERT_EQ(h.status, 0u) << what << ": stack overflow";
        ASSERT_EQ(h.prim == NO_HIT, best_tri == NO_HIT)
            << what << ": ray (" << r.o.x << ", " << r.o.y << ", " << r.o.z << ") -> (" << r.d.x
            << ", " << r.d.y << ", " << r.d.z << "), expected " << best_tri << " at " << best
            << ", got " << h.prim << " at " << h.t;
        if (best_tri == NO_HIT) return;
        ASSERT_NEAR(h.t, best, 1e-6f * best) << what << ": " << describe_ray(r) << ", triangle "
                                             << h.prim << " instead of " << best_tri;
    });
}

// Any hit (shadow rays) against brute force, with the tmax a shadow ray has: unbounded, just
// short of the nearest hit (nothing may be found but what lies nearer), and past it. A hit
// is reported exactly when brute force finds one below tmax, and it is a real one: below
// tmax, and the triangle it names, tested alone, gives the same t. Plain and overlapped
// steps; stops at the first fatal failure.
TEST(KdTreeTraversal, AnyHitMatchesBruteForce) {
    size_t hits = 0, misses = 0;
    for_each_device_ray(14, [&](const std::string& what, const std::vector<gpu::GpuTriangle>& g,
                                const KdTree& tree, const TestRay& r, const gpu::Ray& unbounded) {
        const gpu::Hit nearest = brute_force_hit(g, unbounded);
        std::vector<float> tmaxes = {unbounded.tmax};
        if (nearest.prim != NO_HIT) tmaxes.insert(tmaxes.end(), {nearest.t * 0.999f, nearest.t * 1.5f});
        for (float tmax : tmaxes) {
            gpu::Ray ray = unbounded;
            ray.tmax = tmax;
            const gpu::Hit b = brute_force_hit(g, ray);
            for (uint32_t flags : {0u, uint32_t(SCENE_KD_OVERLAP)}) {
                const gpu::Hit h = cpu_trace_tree(tree, g, ray, true, flags);
                const std::string at = what + ": " + describe_ray(r) + ", tmax " +
                                       std::to_string(tmax) + (flags ? " (overlapped)" : "");
                ASSERT_EQ(h.status, 0u) << at;
                ASSERT_EQ(h.prim == NO_HIT, b.prim == NO_HIT)
                    << at << ": any hit " << h.prim << " at " << h.t << ", brute force "
                    << b.prim << " at " << b.t;
                if (h.prim == NO_HIT) {
                    ++misses;
                    continue;
                }
                ++hits;
                ASSERT_LT(h.prim, g.size()) << at;
                ASSERT_LT(h.t, tmax) << at;
                const gpu::TriHit alone = gpu::intersect_triangle(ray, gpu::woop_setup(ray.d), g[h.prim]);
                ASSERT_TRUE(alone.hit) << at << ": triangle " << h.prim << " is not hit";
                ASSERT_EQ(alone.t, h.t) << at << ": triangle " << h.prim;
            }
        }
    });
    std::printf("any hit: %zu hits and %zu misses as brute force\n", hits, misses);
    EXPECT_GT(hits, 100u);
    EXPECT_GT(misses, 100u);
}

// Overlapped steps (traverse.h: KD_OVERLAP, on in the device builds) give every hit of the
// plain loop bit for bit, closest and any: the same leaves in the same order. They may visit
// nodes the pending triangles would have culled: more visits, never fewer.
TEST(KdTreeTraversal, OverlappedStepsGiveTheSameHits) {
    size_t plain_visits = 0, overlap_visits = 0;
    for_each_device_ray(13, [&](const std::string& what, const std::vector<gpu::GpuTriangle>& g,
                                const KdTree& tree, const TestRay& r, const gpu::Ray& ray) {
        for (bool any_hit : {false, true}) {
            const gpu::Hit a = cpu_trace_tree(tree, g, ray, any_hit);
            const gpu::Hit b = cpu_trace_tree(tree, g, ray, any_hit, SCENE_KD_OVERLAP);
            const std::string at = what + ": " + describe_ray(r) + (any_hit ? " (any hit)" : "");
            ASSERT_EQ(a.status, b.status) << at;
            ASSERT_EQ(a.prim, b.prim) << at;
            ASSERT_EQ(std::memcmp(&a.t, &b.t, 4), 0) << at;
            ASSERT_EQ(std::memcmp(&a.b1, &b.b1, 4), 0) << at;
            ASSERT_EQ(std::memcmp(&a.b2, &b.b2, 4), 0) << at;
            ASSERT_GE(b.node_visits, a.node_visits) << at;
            plain_visits += a.node_visits, overlap_visits += b.node_visits;
        }
    });
    // The overlapped path ran: some node it visited, the plain loop had culled.
    EXPECT_GT(overlap_visits, plain_visits);
}

// Work per ray on a 49k-triangle bumpy sphere, a stand-in for the 47,794-triangle dragon
// (the target there: at most 12 triangle tests per ray; this mesh measures about 11).
TEST(KdTreeQuality, FewTriangleTestsPerRayOnALargeMesh) {
    const std::vector<Triangle> tris = blob(64, 0.04f);
    const KdTree tree = build_kdtree(tris, options(TreeKind::Sah, -1));
    EXPECT_LT(double(tree.stats.bytes) / double(tris.size()), 40.0);
    std::mt19937 rng(9);
    std::uniform_real_distribution<float> u(0.f, 1.f);
    const vec3 lo = tree.bounds.min, extent = tree.bounds.max - tree.bounds.min;
    const float radius = glm::length(extent);
    const int n = 4000;
    size_t tests = 0;
    for (int i = 0; i < n; ++i) {
        // From a sphere around the mesh toward a random point of its bounds.
        const float z = 1 - 2 * u(rng), phi = 6.2831853f * u(rng), s = std::sqrt(1 - z * z);
        const vec3 o = radius * vec3(s * std::cos(phi), s * std::sin(phi), z);
        const vec3 target = lo + extent * vec3(u(rng), u(rng), u(rng));
        const TestHit hit = trace_tree(tree, tris, {o, glm::normalize(target - o)});
        ASSERT_FALSE(hit.overflow);
        tests += hit.tests;
    }
    const double per_ray = double(tests) / n;
    RecordProperty("triangle_tests_per_ray", std::to_string(per_ray));
    EXPECT_LE(per_ray, 12.0);
}

}  // namespace
}  // namespace mcpt

namespace mcpt {
namespace {

// GLSL and OpenCL read each 40-byte triangle as five 8-byte words: the words rebuild it.
TEST(DeviceLayout, TriangleFromWordsRebuildsTheTriangle) {
    const gpu::GpuTriangle t{1.5f, -2.f, 3.25f, -0.f, 1e-30f, 7.f, 1e30f, -8.5f, 9.f, 12345u};
    glm::uvec2 w[5];
    std::memcpy(w, &t, sizeof t);
    const gpu::GpuTriangle r = gpu::triangle_from_words(w[0], w[1], w[2], w[3], w[4]);
    EXPECT_EQ(std::memcmp(&r, &t, sizeof t), 0);
}

}  // namespace
}  // namespace mcpt
