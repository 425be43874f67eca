// k-d tree over a scene's triangles, built on the host and flattened for the device:
// 8-byte pbrt-style nodes in pre-order (below child = next node) plus a leaf index array.
#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include "common/gpu/shared_types.h"
#include "common/scene/scene.h"

namespace mcpt {

// Auto: the BVH, or none where the cost model says testing every triangle is cheaper (the
// BVH ran faster than the SAH k-d tree on every device measured: docs/traversal.md).
// Bvh: the 8-wide BVH (wide_bvh.h), which travels in the same struct.
// RayQuery, RayPipeline: no tree on the host (one leaf, as None); the Vulkan device builds
// acceleration structures and its driver traces, through ray queries (VK_KHR_ray_query) or
// the ray-tracing pipeline (VK_KHR_ray_tracing_pipeline).
enum class TreeKind { Sah, Median, None, Auto, Bvh, RayQuery, RayPipeline };
inline bool traced_by_driver(TreeKind k) {
    return k == TreeKind::RayQuery || k == TreeKind::RayPipeline;
}

// "sah" | "median" | "none" | "auto" | "bvh" | "rayquery" | "raypipeline"; throws mcpt::Error
// otherwise.
TreeKind parse_tree_kind(const std::string& name);
const char* tree_kind_name(TreeKind kind);
// Every name parse_tree_kind() takes, "auto" first (the commands' --tree choices).
std::vector<std::string> tree_kind_names();

// Device costs in units of one triangle test: a k-d node visit, the fixed work of entering
// the tree (clipping to the scene bounds, the stack), and a BVH node visit (eight child
// boxes). Measured with mcpt render --tree sah|bvh|none on the Cornell box (12 triangles)
// and a cube in it (24), 256x256:
//  - SIMT: GPUs and lavapipe run invocations as SIMD lanes, where divergent traversal
//    idles lanes: lavapipe renders both scenes 2x faster without the k-d tree, and as fast
//    through the BVH as without a tree (6.2 and 6.1 M rays/s on the Cornell box).
//  - scalar: PoCL's CPU work-items: the k-d tree is 1.2-1.4x faster on both, the BVH 1.07x
//    faster than no tree on the Cornell box.
struct TreeCostModel {
    const char* name;
    double node_visit, tree_entry, wide_node_visit;
};
constexpr TreeCostModel kSimtCostModel{"SIMT", 1.0, 8.0, 2.0};
constexpr TreeCostModel kScalarCostModel{"scalar", 0.2, 1.0, 0.5};

struct TreeOptions {
    TreeKind kind = TreeKind::Sah;
    int max_depth = -1;       // -1: 8 + 1.3 log2 N for SAH; the median tree needs a depth
    float isect_cost = 80.f;  // pbrt-v3 KdTreeAccel costs
    float traversal_cost = 1.f;
    float empty_bonus = 0.5f;
    int max_leaf_prims = 1;                     // SAH: a node this small becomes a leaf
    int threads = 0;                            // 0: the CPUs this process may use (usable_cpus())
    TreeCostModel auto_model = kSimtCostModel;  // TreeKind::Auto: the device's costs
    // Bvh: each wide node's children by the SAH-optimal collapse (wide_bvh.cpp); false: the
    // largest child opened first ($MCPT_BVH_COLLAPSE=0, tree_options()).
    bool bvh_optimal_collapse = true;
};

struct TreeStats {
    size_t nodes = 0, leaves = 0, empty_leaves = 0;
    int max_depth = 0;          // deepest leaf (root = 0)
    double mean_leaf_size = 0;  // triangle references per non-empty leaf
    size_t references = 0;      // entries of the leaf index array
    double build_seconds = 0;
    int threads = 0;   // the build's threads
    size_t bytes = 0;  // nodes + leaf indices
};

struct KdTree {
    // Pre-order k-d nodes, nodes[0] the root; or, for TreeKind::Bvh, the BVH's nodes
    // (gpu::BvhNode, BVH_NODE_UNITS entries each: the tree buffer's 8-byte units).
    std::vector<gpu::KdNode> nodes;
    std::vector<uint32_t> leaf_indices;  // triangle indices referenced by leaves
    Bounds bounds;                       // of all triangles (may be empty)
    TreeStats stats;
    TreeKind kind = TreeKind::None;  // the tree built (never Auto)
    std::string auto_choice;         // TreeKind::Auto: what it chose and why
    // Traversal stack entries needed: max_depth + 1 (never smaller than 1).
    uint32_t stack_size() const { return static_cast<uint32_t>(stats.max_depth) + 1; }
};

// Builds the tree. TreeKind::None gives a single leaf holding every triangle, so the same
// traversal code runs without a tree; TreeKind::Bvh the wide BVH (build_wide_bvh).
KdTree build_kdtree(const std::vector<Triangle>& triangles, const TreeOptions& options);

// Expected cost of one ray through a tree, from surface areas (the SAH's own model, without
// early termination): node visits and triangle tests of a ray crossing the scene bounds.
struct TreeCost {
    double node_visits = 0, triangle_tests = 0;
};
TreeCost expected_tree_cost(const KdTree& tree);

// --tree auto: the tree given (the BVH) or none, whichever the cost model expects to be
// cheaper.
struct TreeChoice {
    TreeKind kind = TreeKind::Sah;
    double cost_tree = 0, cost_none = 0;  // in triangle tests
    std::string reason;                   // one line for --verbose
};
TreeChoice choose_tree(const KdTree& tree, size_t triangle_count, const TreeCostModel& model);

// Multi-line human-readable statistics of a tree of `kind`.
std::string describe(const TreeStats& stats, size_t triangle_count, TreeKind kind = TreeKind::Sah);

}  // namespace mcpt
