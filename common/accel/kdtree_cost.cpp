// --tree auto: the expected cost of a ray through a tree, from the surface area heuristic's
// own model, and the choice between the SAH tree and none that follows from it.
#include <cstdio>
#include <algorithm>
#include <cstring>
#include <vector>

#include "common/accel/kdtree.h"
#include "common/accel/wide_bvh.h"

namespace mcpt {

// The BVH: every node is entered with probability area(node) / area(root), its children's
// boxes all tested there, and a leaf's triangles with its box's probability.
TreeCost expected_bvh_cost(const KdTree& tree) {
    TreeCost c;
    const double lo[3] = {tree.bounds.min.x, tree.bounds.min.y, tree.bounds.min.z};
    const double hi[3] = {tree.bounds.max.x, tree.bounds.max.y, tree.bounds.max.z};
    const double root_area = half_area(lo, hi);
    c.node_visits = 1;
    const uint32_t n = bvh_node_count(tree);
    for (uint32_t i = 0; i < n; ++i) {
        for (const BvhChild& ch : bvh_children(bvh_node(tree, i))) {
            const double p = root_area > 0 ? std::min(1.0, half_area(ch.lo, ch.hi) / root_area) : 1.0;
            if (ch.internal)
                c.node_visits += p;
            else
                c.triangle_tests += p * ch.triangles;
        }
    }
    return c;
}

TreeCost expected_tree_cost(const KdTree& tree) {
    TreeCost c;
    if (tree.kind == TreeKind::Bvh) return tree.bounds.empty() ? c : expected_bvh_cost(tree);
    if (tree.nodes.empty() || tree.bounds.empty()) return c;
    struct Item {
        uint32_t node;
        float lo[3], hi[3];
    };
    Item root{0,
              {tree.bounds.min.x, tree.bounds.min.y, tree.bounds.min.z},
              {tree.bounds.max.x, tree.bounds.max.y, tree.bounds.max.z}};
    const double root_area = half_area(root.lo, root.hi);
    if (!(root_area > 0)) {
        // A line or a point: every ray that hits tests every leaf it passes; count them all.
        c.node_visits = double(tree.nodes.size());
        c.triangle_tests = double(tree.leaf_indices.size());
        return c;
    }
    // Each node is reached with probability area(node) / area(root) (the SAH's model).
    std::vector<Item> stack{root};
    while (!stack.empty()) {
        const Item it = stack.back();
        stack.pop_back();
        const gpu::KdNode n = tree.nodes[it.node];
        const double p = half_area(it.lo, it.hi) / root_area;
        c.node_visits += p;
        const uint32_t axis = n.flags & 3u;
        if (axis == KD_LEAF) {
            c.triangle_tests += p * double(n.flags >> 2);
            continue;
        }
        float split;
        std::memcpy(&split, &n.split_or_offset, 4);
        Item below = it, above = it;
        below.node = it.node + 1, above.node = n.flags >> 2;
        below.hi[axis] = split, above.lo[axis] = split;
        stack.push_back(below);
        stack.push_back(above);
    }
    return c;
}

TreeChoice choose_tree(const KdTree& tree, size_t triangle_count, const TreeCostModel& m) {
    TreeChoice ch;
    const TreeCost c = expected_tree_cost(tree);
    const double visit = tree.kind == TreeKind::Bvh ? m.wide_node_visit : m.node_visit;
    ch.cost_tree = m.tree_entry + visit * c.node_visits + c.triangle_tests;
    ch.cost_none = double(triangle_count);
    ch.kind = ch.cost_tree < ch.cost_none ? tree.kind : TreeKind::None;
    char buf[256];
    std::snprintf(buf, sizeof buf,
                  "tree auto: %s (%s device; expected cost per ray in triangle tests: %s "
                  "%.1f, from %.1f node visits and %.1f triangle tests; no tree %.0f)",
                  tree_kind_name(ch.kind), m.name, tree_kind_name(tree.kind), ch.cost_tree,
                  c.node_visits, c.triangle_tests, ch.cost_none);
    ch.reason = buf;
    return ch;
}

}  // namespace mcpt
