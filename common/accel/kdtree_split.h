// The k-d tree builder's split rules (kdtree.cpp's engine asks one per node): pbrt-v3's SAH,
// searched binned on large nodes and exactly on small ones, and the 2015 thesis's median
// split. The types the engine and the rules share; internal to common/accel.
#pragma once
#include <cstddef>
#include <cstdint>
#include <memory>
#include <vector>

#include "common/accel/kdtree.h"

namespace mcpt::kdbuild {

struct Box {
    float lo[3], hi[3];
};

// A triangle's reference in a node: its bounds clipped to the node, and its index.
struct Ref {
    float lo[3], hi[3];
    uint32_t tri;
};

// A node's split, or a leaf when axis < 0.
struct Split {
    int axis = -1;
    float pos = 0.f;
    int bad_refines = 0;
    bool clip_exact = false;  // clip straddling triangles to the child boxes exactly
};

// Per-worker buffers, reused from node to node.
struct Scratch {
    std::vector<Ref> arena;  // references of the pending nodes, the current one on top
    std::vector<uint64_t> events;
    std::vector<float> keys;
};

// How a tree kind splits a node (refs: the node's references).
class SplitRule {
  public:
    virtual ~SplitRule() = default;
    virtual Split choose(const Ref* refs, size_t n, const Box& box, const Box& refs_union,
                         int depth, int bad_refines, Scratch& scratch) const = 0;
};

// pbrt-v3's SAH rule (TreeOptions' costs and leaf size) to at most max_depth levels.
std::unique_ptr<SplitRule> sah_rule(const TreeOptions& options, int max_depth);
// The median triangle centroid on axes in turn, to exactly max_depth levels.
std::unique_ptr<SplitRule> median_rule(const std::vector<Triangle>& triangles, int max_depth);

}  // namespace mcpt::kdbuild
