// Two-level k-d nodes from the binary tree (shared_types.h: KD_WIDE_*): each node takes a
// binary node and its two children, so a traversal step decides two levels with one 32-byte
// fetch. The planes, leaves and leaf order are the binary tree's: a ray meets the same leaves
// in the same order, and empty leaves are dropped from their parents.
#include <algorithm>

#include "common/accel/kdtree.h"
#include "common/error.h"

namespace mcpt {

namespace {

bool is_leaf(const gpu::KdNode& n) {
    return (n.flags & 3u) == KD_LEAF;
}

struct Widener {
    const KdTree& in;
    std::vector<gpu::KdNode> nodes;   // two-level nodes, four units each
    std::vector<gpu::KdNode> leaves;  // non-empty leaves, after them
    uint32_t depth = 0;

    // The child word of binary node b, whose two-level parent is at `level` (root: 1).
    uint32_t child(uint32_t b, uint32_t level) {
        const gpu::KdNode& n = in.nodes[b];
        if (!is_leaf(n)) return node(b, level + 1);
        if ((n.flags >> 2) == 0) return KD_WIDE_EMPTY;
        leaves.push_back(n);
        return KD_WIDE_LEAF_BIT | uint32_t(leaves.size() - 1);  // unit fixed up at the end
    }

    // A two-level node for interior binary node b; returns its first unit.
    uint32_t node(uint32_t b, uint32_t level) {
        depth = std::max(depth, level);
        const size_t self = nodes.size();
        nodes.resize(self + 4);
        const gpu::KdNode& root = in.nodes[b];
        uint32_t axes = root.flags & 3u;
        uint32_t split[2] = {0u, 0u},
                 children[4] = {KD_WIDE_EMPTY, KD_WIDE_EMPTY, KD_WIDE_EMPTY, KD_WIDE_EMPTY};
        const uint32_t halves[2] = {b + 1, root.flags >> 2};
        for (uint32_t h = 0; h < 2; ++h) {
            const gpu::KdNode& half = in.nodes[halves[h]];
            if (is_leaf(half)) {
                axes |= h == 0 ? KD_WIDE_DIRECT_BELOW : KD_WIDE_DIRECT_ABOVE;
                children[2 * h] = child(halves[h], level);
                continue;
            }
            axes |= (half.flags & 3u) << (2 * (h + 1));
            split[h] = half.split_or_offset;
            children[2 * h] = child(halves[h] + 1, level);
            children[2 * h + 1] = child(half.flags >> 2, level);
        }
        nodes[self] = {root.split_or_offset, axes};
        nodes[self + 1] = {split[0], split[1]};
        nodes[self + 2] = {children[0], children[1]};
        nodes[self + 3] = {children[2], children[3]};
        return uint32_t(self);
    }
};

}  // namespace

KdTree widen_kdtree(const KdTree& binary) {
    if (binary.wide) throw Error("widen_kdtree: the tree is already two-level");
    KdTree out = binary;
    if (binary.nodes.empty() || is_leaf(binary.nodes[0])) return out;
    Widener w{binary, {}, {}, 0};
    w.node(0, 1);
    // Leaves after the two-level nodes: their child words become units.
    const uint32_t first_leaf = uint32_t(w.nodes.size());
    if (uint64_t(first_leaf) + w.leaves.size() >= KD_WIDE_LEAF_BIT)
        throw Error("k-d tree too large for two-level nodes");
    for (size_t i = 0; i < w.nodes.size(); i += 4)
        for (size_t u = i + 2; u < i + 4; ++u)
            for (uint32_t* c : {&w.nodes[u].split_or_offset, &w.nodes[u].flags})
                if (*c != KD_WIDE_EMPTY && (*c & KD_WIDE_LEAF_BIT) != 0) *c += first_leaf;
    out.nodes = std::move(w.nodes);
    out.nodes.insert(out.nodes.end(), w.leaves.begin(), w.leaves.end());
    out.wide = true;
    out.wide_depth = w.depth;
    out.stats.bytes = out.nodes.size() * sizeof(gpu::KdNode) + out.leaf_indices.size() * 4;
    return out;
}

}  // namespace mcpt
