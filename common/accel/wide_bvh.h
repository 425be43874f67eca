// The 8-wide BVH (gpu::BvhNode, after Ylitie, Karras & Laine 2017) over a scene's
// triangles, beside the k-d tree: a binned-SAH binary BVH built on the host's threads,
// collapsed to eight children per node (by the SAH, each child's box as its node quantizes
// it; or the largest child opened first), children placed in
// the slots of the octants they are nearest along, and their boxes quantized conservatively
// (to a grid, stored as float offsets from its origin).
// It travels in a KdTree of kind TreeKind::Bvh: `nodes` holds the BVH nodes' bytes
// (BVH_NODE_UNITS 8-byte units each) and `leaf_indices` the leaves' triangles.
#pragma once
#include <cstdint>
#include <vector>

#include "common/accel/kdtree.h"

namespace mcpt {

// A box's half surface area (float or double corners), in double: float boxes up to 3.4e38
// wide stay finite. (The builder's SAH, bvh_sah_cost and kdtree_cost.cpp's.)
template <class T>
double half_area(const T lo[3], const T hi[3]) {
    const double dx = double(hi[0]) - lo[0], dy = double(hi[1]) - lo[1], dz = double(hi[2]) - lo[2];
    return dx * dy + dy * dz + dz * dx;
}

// Builds the BVH (options: threads; the k-d tree's depth and costs do not apply).
KdTree build_wide_bvh(const std::vector<Triangle>& triangles, const TreeOptions& options);

// Node i of a TreeKind::Bvh tree, and writing it back (tests plant faults this way).
gpu::BvhNode bvh_node(const KdTree& tree, uint32_t i);
void set_bvh_node(KdTree& tree, uint32_t i, const gpu::BvhNode& node);
uint32_t bvh_node_count(const KdTree& tree);

// One child of a node, decoded: an internal node (its index) or a leaf (its first leaf index
// and triangle count), with the box the traversal tests (quantized, so at least its
// content's box).
struct BvhChild {
    int slot = 0;
    bool internal = false;
    uint32_t index = 0;      // node index, or first entry of the leaf index array
    uint32_t triangles = 0;  // leaf: 1 to BVH_LEAF_MAX
    double lo[3] = {0, 0, 0}, hi[3] = {0, 0, 0};  // exactly as quantized
};
std::vector<BvhChild> bvh_children(const gpu::BvhNode& node);

// The tree's SAH cost relative to its root's box: every slot's quantized box's half area
// over the root's, times `node` for an internal child or `triangle` per triangle of a leaf
// (0 for a tree without triangles).
double bvh_sah_cost(const KdTree& tree, double node, double triangle);

// The quantized plane (low or high) of a slot on an axis, as a byte of the node; tests move
// one by a grid cell to plant a box that misses part of its content.
uint32_t bvh_plane(const gpu::BvhNode& node, int axis, bool high, int slot);
void set_bvh_plane(gpu::BvhNode& node, int axis, bool high, int slot, uint32_t q);

}  // namespace mcpt
