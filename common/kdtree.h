// k-d tree over a scene's triangles, built on the host and flattened for the device:
// 8-byte pbrt-style nodes in pre-order (below child = next node) plus a leaf index array.
#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include "gpu/shared_types.h"
#include "scene.h"

namespace mcpt {

enum class TreeKind { Sah, Median, None };

// "sah" | "median" | "none"; throws mcpt::Error otherwise.
TreeKind parse_tree_kind(const std::string& name);
const char* tree_kind_name(TreeKind kind);

struct TreeOptions {
    TreeKind kind = TreeKind::Sah;
    int max_depth = -1;         // -1: 8 + 1.3 log2 N for SAH; the median tree needs a depth
    float isect_cost = 80.f;    // pbrt-v3 KdTreeAccel costs
    float traversal_cost = 1.f;
    float empty_bonus = 0.5f;
    int max_leaf_prims = 1;     // SAH: a node this small becomes a leaf
    int threads = 0;            // 0: hardware concurrency
};

struct TreeStats {
    size_t nodes = 0, leaves = 0, empty_leaves = 0;
    int max_depth = 0;           // deepest leaf (root = 0)
    double mean_leaf_size = 0;   // triangle references per non-empty leaf
    size_t references = 0;       // entries of the leaf index array
    double build_seconds = 0;
    size_t bytes = 0;            // nodes + leaf indices
};

struct KdTree {
    std::vector<gpu::KdNode> nodes;      // pre-order; nodes[0] is the root
    std::vector<uint32_t> leaf_indices;  // triangle indices referenced by leaves
    Bounds bounds;                       // of all triangles (may be empty)
    TreeStats stats;
    // Traversal stack entries needed: max_depth + 1 (never smaller than 1).
    uint32_t stack_size() const { return static_cast<uint32_t>(stats.max_depth) + 1; }
};

// Builds the tree. TreeKind::None gives a single leaf holding every triangle, so the same
// traversal code runs without a tree.
KdTree build_kdtree(const std::vector<Triangle>& triangles, const TreeOptions& options);

// Multi-line human-readable statistics.
std::string describe(const TreeStats& stats, size_t triangle_count);

}  // namespace mcpt
