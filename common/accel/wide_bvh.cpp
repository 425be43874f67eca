// Construction of the 8-wide BVH (common/accel/wide_bvh.h):
//  1. a binary BVH by binned SAH over triangle box centroids (16 bins, or one a reference
//     below 16, on the axis of largest centroid extent), the two children of large nodes
//     built on two threads;
//  2. each wide node collapsed from a binary subtree, by the SAH-optimal collapse (Ylitie et
//     al., section 4.1: a table of least costs a binary node and slot budget, bottom-up; then
//     each node's children chosen with their boxes as it quantizes them); or, without
//     TreeOptions::bvh_optimal_collapse, the child of largest surface area opened until eight
//     children or none left to open;
//  3. children placed in slots greedily by their centre along each octant's direction (a
//     node of leaves only: in order, from slot 0), the internal ones stored contiguously in
//     breadth-first order, the leaves' triangles contiguously per node;
//  4. child boxes quantized per axis to a grid 2^e from p = the node's lower corner less a cell,
//     every box widened by a further cell, so the traversal's rounding never shrinks a box;
//     each plane stored as its offset from p in float (exact), which the traversal uses as is.
#include "common/accel/wide_bvh.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstring>
#include <deque>
#include <future>
#include <limits>
#include <memory>

#include "common/error.h"
#include "common/io/host_cpus.h"

namespace mcpt {

namespace {

constexpr int kSahBins = 16;
constexpr size_t kParallelMin = 16384;  // a node this large builds its children on two threads
// The optimal collapse's costs: a wide node's visit, in triangle tests (kSimtCostModel's).
constexpr float kCollapseNodeCost = float(kSimtCostModel.wide_node_visit);
constexpr float kCollapseTriangleCost = 1.f;

// A triangle's reference: its box and index, moved as the build partitions (sequential
// reads at every level, not gathers through an index).
struct Prim {
    float lo[3], hi[3];
    uint32_t tri;
};

// A box's centre on axis a (halves first: no overflow at 3.4e38).
float centroid(const Prim& p, int a) {
    return 0.5f * p.lo[a] + 0.5f * p.hi[a];
}

// A binary node: a leaf (count > 0) of refs[first, first + count), or children left, right;
// `below` triangles in its subtree, whose references are refs[first, first + below).
struct BinNode {
    float lo[3], hi[3];
    uint32_t left = 0, right = 0, first = 0, count = 0, below = 0;
};

// Bins of centroid coordinates over [lo, hi]: in float where every term is a normal float
// well inside range (any mesh), else in double (finite for any finite floats, denormal
// extents included). Binning and partitioning use the same one, so they agree.
struct Binner {
    float lo = 0, scale_f = 0;
    double scale_d = 0;
    bool in_float = false;
    int bins = kSahBins;
    Binner(float lo_, float hi_, int bins_) : lo(lo_), bins(bins_) {
        const double extent = double(hi_) - lo_;
        scale_d = double(bins) / extent;
        scale_f = float(scale_d);
        in_float = extent > 1e-30 && extent < 1e30 && std::abs(lo_) < 1e30 && std::abs(hi_) < 1e30;
    }
    int operator()(float c) const {
        if (in_float) {
            const float x = (c - lo) * scale_f;
            return x >= float(bins - 1) ? bins - 1 : (x > 0 ? int(x) : 0);
        }
        const double x = (double(c) - lo) * scale_d;
        return x >= double(bins - 1) ? bins - 1 : (x > 0 ? int(x) : 0);
    }
};

// A range's box and its references' centroid box.
struct Boxes {
    float lo[3], hi[3], clo[3], chi[3];
    bool known = false;  // filled (by the parent's bins); else computed by a pass
    void clear() {
        for (int a = 0; a < 3; ++a) {
            lo[a] = clo[a] = std::numeric_limits<float>::max();
            hi[a] = chi[a] = -std::numeric_limits<float>::max();
        }
    }
    void add(const Boxes& b) {
        for (int a = 0; a < 3; ++a) {
            lo[a] = std::min(lo[a], b.lo[a]), hi[a] = std::max(hi[a], b.hi[a]);
            clo[a] = std::min(clo[a], b.clo[a]), chi[a] = std::max(chi[a], b.chi[a]);
        }
    }
    void add(const Prim& p) {
        for (int a = 0; a < 3; ++a) {
            lo[a] = std::min(lo[a], p.lo[a]), hi[a] = std::max(hi[a], p.hi[a]);
            const float c = centroid(p, a);
            clo[a] = std::min(clo[a], c), chi[a] = std::max(chi[a], c);
        }
    }
};

struct BinaryBuilder {
    std::vector<Prim>& refs;

    // The subtree over refs[begin, end) appended to `out`; returns its root's index there.
    // `boxes`: the range's boxes if its parent's bins gave them (the same floats a pass over
    // the range gives: minima and maxima are exact).
    uint32_t build(uint32_t begin, uint32_t end, std::vector<BinNode>& out, int threads,
                   Boxes boxes) {
        if (!boxes.known) {
            boxes.clear();
            for (uint32_t i = begin; i < end; ++i) boxes.add(refs[i]);
        }
        BinNode node;
        for (int a = 0; a < 3; ++a) node.lo[a] = boxes.lo[a], node.hi[a] = boxes.hi[a];
        const uint32_t at = uint32_t(out.size());
        node.first = begin, node.below = end - begin;
        out.push_back(node);
        const uint32_t count = end - begin;
        Boxes left_boxes, right_boxes;
        const uint32_t mid = split(begin, end, boxes.clo, boxes.chi, left_boxes, right_boxes);
        if (mid == begin) {
            out[at].count = count;
            return at;
        }
        if (threads > 1 && count >= kParallelMin) {
            // The left child on another thread, into its own array, linked in after the right
            // one, built here in place (the 871k dragon's nodes are 38 MB: one array fewer to
            // fill and copy). (About n nodes for n references, leaves holding 1-3: a hint,
            // they grow past it.)
            std::vector<BinNode> left_nodes;
            left_nodes.reserve(mid - begin);
            auto left = std::async(std::launch::async,
                                   [&] { build(begin, mid, left_nodes, threads / 2, left_boxes); });
            out[at].right = build(mid, end, out, threads - threads / 2, right_boxes);
            left.get();
            out[at].left = uint32_t(out.size());
            append(left_nodes, out);
        } else {
            out[at].left = build(begin, mid, out, 1, left_boxes);
            out[at].right = build(mid, end, out, 1, right_boxes);
        }
        return at;
    }

    static void append(const std::vector<BinNode>& sub, std::vector<BinNode>& out) {
        const uint32_t base = uint32_t(out.size());
        for (BinNode n : sub) {
            if (n.count == 0) n.left += base, n.right += base;
            out.push_back(n);
        }
    }

    // Partitions refs[begin, end) by the best binned SAH plane; returns the first of the
    // upper part, or begin for a leaf. The parts' boxes, from the bins, into left and right.
    uint32_t split(uint32_t begin, uint32_t end, const float clo[3], const float chi[3],
                   Boxes& left, Boxes& right) {
        const uint32_t count = end - begin;
        // At most BVH_LEAF_MAX: one wide leaf whatever lies below (Collapser::is_leaf), so no
        // split (the bins' fixed cost was most of the build's time at the bottom levels).
        if (count <= BVH_LEAF_MAX) return begin;
        struct Bin {
            uint32_t n;
            Boxes boxes;  // its references' boxes, centroids included
        };
        Bin bins[kSahBins];
        // A bin per reference below kSahBins: the same work per ray on the meshes, the 871k
        // dragon built 3% faster (fewer bins to clear and sweep at the bottom levels).
        const int nb = count < uint32_t(kSahBins) ? int(count) : kSahBins;
        double best_cost = std::numeric_limits<double>::infinity();
        int best_axis = -1, best_bin = 0;
        // Binned on the axis of the centroids' largest extent: all three axes built the 871k
        // dragon 2.1x slower (0.92 against 0.43 s on 2 cores) for no fewer node visits per ray
        // (9.1 against 9.0 on wide_bvh_test's 49k-triangle blob).
        int longest = 0;
        for (int a = 1; a < 3; ++a)
            if (double(chi[a]) - clo[a] > double(chi[longest]) - clo[longest]) longest = a;
        for (int a = longest; a == longest; ++a) {
            if (!(chi[a] > clo[a])) continue;
            for (int b = 0; b < nb; ++b) bins[b].n = 0, bins[b].boxes.clear();
            const Binner bin_of(clo[a], chi[a], nb);
            for (uint32_t i = begin; i < end; ++i) {
                const Prim& p = refs[i];
                Bin& bin = bins[bin_of(centroid(p, a))];
                bin.n += 1;
                bin.boxes.add(p);
            }
            // Sweep: areas and counts left of each boundary, then right of it.
            double left_cost[kSahBins];
            Boxes acc = bins[0].boxes;
            uint32_t n = 0;
            for (int b = 0; b < nb - 1; ++b) {
                if (b > 0) acc.add(bins[b].boxes);
                n += bins[b].n;
                left_cost[b] = n ? double(half_area(acc.lo, acc.hi)) * n : 0.0;
            }
            acc = bins[nb - 1].boxes;
            n = 0;
            for (int b = nb - 1; b > 0; --b) {
                if (b < nb - 1) acc.add(bins[b].boxes);
                n += bins[b].n;
                const double cost =
                    left_cost[b - 1] + (n ? double(half_area(acc.lo, acc.hi)) * n : 0.0);
                if (cost < best_cost && n > 0 && n < count)
                    best_cost = cost, best_axis = a, best_bin = b;
            }
        }
        if (best_axis < 0) return begin + count / 2;  // one centroid: halve by index
        const int a = best_axis;
        const Binner bin_of(clo[a], chi[a], nb);
        Prim* mid = std::partition(refs.data() + begin, refs.data() + end, [&](const Prim& r) {
            return bin_of(centroid(r, a)) < best_bin;
        });
        // The parts' boxes: their bins' together.
        left.clear(), right.clear();
        for (int b = 0; b < nb; ++b)
            if (bins[b].n > 0) (b < best_bin ? left : right).add(bins[b].boxes);
        left.known = right.known = true;
        return uint32_t(mid - refs.data());
    }
};

// The largest float not above x.
float round_down(double x) {
    float f = float(x);
    if (double(f) > x) f = std::nextafter(f, -std::numeric_limits<float>::infinity());
    return f;
}

// Per axis: the grid (exponent, origin p) and the planes of each child.
struct AxisGrid {
    int e = 0;
    float p = 0;
};
AxisGrid axis_grid(double lo, double hi) {
    AxisGrid g;
    const double extent = hi - lo;
    g.e = extent > 0 ? int(std::ceil(std::log2(extent / 250.0))) : -100;
    g.e = std::clamp(g.e, -100, 126);
    for (;; ++g.e) {
        const double cell = std::ldexp(1.0, g.e);
        g.p = round_down(lo - cell);
        if (std::ceil((hi - double(g.p)) / cell) + 1.0 <= 255.0 || g.e >= 126) return g;
    }
}

// A child's low and high planes on an axis's grid, in cells from its origin: rounded outward
// and widened by one more cell, so the traversal's rounding never shrinks the box. (2^-e is
// exact in double for e in [-100, 126]: the same quotients as a division.)
double grid_below(double x, const AxisGrid& g) {
    return std::floor((x - g.p) * std::ldexp(1.0, -g.e)) - 1.0;
}
double grid_above(double x, const AxisGrid& g) {
    return std::ceil((x - g.p) * std::ldexp(1.0, -g.e)) + 1.0;
}

// A grid plane as a byte, 0-255 (NaN: 0; only boxes beyond float range reach the ends).
uint32_t grid_byte(double q) {
    return q >= 255.0 ? 255u : (q > 0 ? uint32_t(q) : 0u);
}

void put_byte(uint32_t& word, int k, uint32_t v) {
    word = (word & ~(0xffu << (8 * k))) | ((v & 0xffu) << (8 * k));
}
uint32_t get_byte(uint32_t word, int k) {
    return (word >> (8 * k)) & 0xffu;
}

// Word of a plane: quad 2 + 6h + 2a + hi, slot 4h + k in its word k (shared_types.h).
int plane_word(int axis, bool high, int slot) {
    return 4 * int(BVH_PLANES_QUAD + BVH_HALF_QUADS * (slot / 4) + 2 * axis + (high ? 1 : 0)) +
           slot % 4;
}

// A plane's grid index q on a grid of 2^e, as the node stores it: its offset q * 2^e from the
// grid's origin, in float (exact: 8 significant bits; infinite only beyond float range,
// which widens the box).
uint32_t plane_bits(uint32_t q, int e) {
    const uint32_t scale_bits = uint32_t(e + 127) << 23;  // 2^e: e in [-100, 126]
    float scale;
    std::memcpy(&scale, &scale_bits, 4);
    const float d = float(q) * scale;
    uint32_t bits;
    std::memcpy(&bits, &d, 4);
    return bits;
}

// A wide node's children (binary node indices), at most BVH_WIDTH.
struct Kids {
    uint32_t at[BVH_WIDTH];
    size_t n = 0;
    size_t size() const { return n; }
    void push_back(uint32_t b) { at[n++] = b; }
    uint32_t& operator[](size_t k) { return at[k]; }
    uint32_t operator[](size_t k) const { return at[k]; }
    const uint32_t* begin() const { return at; }
    const uint32_t* end() const { return at + n; }
};

// The SAH-optimal collapse (after Ylitie, Karras & Laine 2017, section 4.1), in two steps.
// Bottom-up, for every binary node n and slot budget i (1-8): the least SAH cost of n's
// subtree in at most i child slots of a wide node, and how (n itself in one slot, a leaf or a
// wide node of its own; or its children spread over k and i - k slots). Then, for each wide
// node made from binary node b, its children chosen again with each candidate slot's box as b
// quantizes it (padded by up to two grid cells a side: a thin leaf high in the tree, such as
// a room's light, otherwise looks free and is entered by every ray that nears it), the costs
// below a slot from the table. Costs per unit of half area relative to the root's (so no
// scale overflows or underflows them): a wide node's visit `node`, a triangle's test
// `triangle`.
struct CollapsePlan {
    const std::vector<BinNode>& bin;
    float node, triangle;
    double per_root_area = 1;        // 1 / the root's half area (1 for a flat root)
    std::vector<float> cost;         // [n * BVH_WIDTH + i - 1]
    std::vector<float> spread_cost;  // [n]: n's children spread over eight slots

    CollapsePlan(const std::vector<BinNode>& bin_, float node_, float triangle_)
        : bin(bin_), node(node_), triangle(triangle_) {
        const double root = half_area(bin[0].lo, bin[0].hi);
        if (root > 0 && std::isfinite(root)) per_root_area = 1 / root;
        const size_t w = BVH_WIDTH;
        cost.resize(bin.size() * w), spread_cost.resize(bin.size());
        for (size_t n = bin.size(); n-- > 0;) {  // children follow their parent in `bin`
            const BinNode& b = bin[n];
            const float area = float(half_area(b.lo, b.hi) * per_root_area);
            float* c = &cost[n * w];
            if (b.count > 0) {  // a binary leaf (at most BVH_LEAF_MAX triangles): one slot
                for (size_t i = 0; i < w; ++i) c[i] = area * triangle * float(b.below);
                continue;
            }
            const float* l = &cost[b.left * w];
            const float* r = &cost[b.right * w];
            float spread[BVH_WIDTH + 1];
            for (size_t j = 2; j <= w; ++j) {
                spread[j] = std::numeric_limits<float>::infinity();
                for (size_t k = 1; k < j; ++k)
                    spread[j] = std::min(spread[j], l[k - 1] + r[j - k - 1]);
            }
            spread_cost[n] = spread[w];
            c[0] = area * node + spread[w];
            for (size_t i = 2; i <= w; ++i) c[i - 1] = std::min(c[0], spread[i]);
        }
    }

    // The children of the wide node made from binary node b (not a leaf), into kids.
    void choose(uint32_t b, Kids& kids) const {
        // b's grid, as quantize() will build it (its children's boxes together are b's).
        AxisGrid grid[3];
        for (int a = 0; a < 3; ++a) grid[a] = axis_grid(bin[b].lo[a], bin[b].hi[a]);
        // Candidates below b within seven levels, each once (a tree: one parent each).
        std::vector<Choice> local;
        local.reserve(64);
        const int left = eval(bin[b].left, BVH_WIDTH - 1, grid, local);
        const int right = eval(bin[b].right, BVH_WIDTH - 1, grid, local);
        float best = std::numeric_limits<float>::infinity();
        size_t best_k = 1;
        for (size_t k = 1; k < BVH_WIDTH; ++k) {
            const float c =
                local[size_t(left)].cost[k - 1] + local[size_t(right)].cost[BVH_WIDTH - k - 1];
            if (c < best) best = c, best_k = k;
        }
        emit(local, left, best_k, kids);
        emit(local, right, BVH_WIDTH - best_k, kids);
    }

  private:
    // A candidate's least cost in at most i slots (i = 1 to its budget), and how: 0 = one
    // slot, else k slots for its left child (`left`, `right`: their entries in `local`).
    struct Choice {
        uint32_t n;
        int left = -1, right = -1;
        float cost[BVH_WIDTH];
        uint8_t k[BVH_WIDTH];
    };

    // Binary node n as a slot of b's node, given at most `budget` slots; its entry in local.
    int eval(uint32_t n, size_t budget, const AxisGrid grid[3], std::vector<Choice>& local) const {
        const BinNode& x = bin[n];
        // Its box as quantized in b's grid, from the grid's origin.
        double lo[3], hi[3];
        for (int a = 0; a < 3; ++a) {
            const double cell = std::ldexp(1.0, grid[a].e);
            lo[a] = grid_below(x.lo[a], grid[a]) * cell,
            hi[a] = grid_above(x.hi[a], grid[a]) * cell;
        }
        const float area = float(half_area(lo, hi) * per_root_area);
        const float one =
            x.count > 0 ? area * triangle * float(x.below) : area * node + spread_cost[n];
        const int at = int(local.size());
        local.push_back(Choice{n, -1, -1, {}, {}});
        for (size_t i = 0; i < BVH_WIDTH; ++i)
            local[size_t(at)].cost[i] = one, local[size_t(at)].k[i] = 0;
        if (x.count > 0 || budget < 2) return at;
        const int l = eval(x.left, budget - 1, grid, local);
        const int r = eval(x.right, budget - 1, grid, local);
        Choice& c = local[size_t(at)];
        c.left = l, c.right = r;
        for (size_t i = 2; i <= budget; ++i)
            for (size_t k = 1; k < i; ++k) {
                const float s = local[size_t(l)].cost[k - 1] + local[size_t(r)].cost[i - k - 1];
                if (s < c.cost[i - 1]) c.cost[i - 1] = s, c.k[i - 1] = uint8_t(k);
            }
        for (size_t i = budget + 1; i <= BVH_WIDTH; ++i)  // (never asked for)
            c.cost[i - 1] = c.cost[budget - 1], c.k[i - 1] = c.k[budget - 1];
        return at;
    }

    // Candidate `at`'s slots given i of them.
    void emit(const std::vector<Choice>& local, int at, size_t i, Kids& kids) const {
        const Choice& c = local[size_t(at)];
        const uint8_t k = c.k[i - 1];
        if (k == 0) {
            kids.push_back(c.n);
            return;
        }
        emit(local, c.left, k, kids);
        emit(local, c.right, i - k, kids);
    }
};

struct Collapser {
    const std::vector<BinNode>& bin;
    const std::vector<Prim>& refs;
    std::vector<gpu::BvhNode> nodes;
    std::vector<uint32_t> leaf_indices;
    TreeStats stats;
    uint32_t allocated = 1;  // node indices handed out (the root's is 0)
    const CollapsePlan* plan = nullptr;  // the SAH-optimal collapse; null: largest area first

    // The wide subtree of binary node `root`, breadth first: nodes[0] is its root, and each
    // node's internal children follow one another.
    void run(uint32_t root) {
        struct Item {
            uint32_t bin;
            int depth;
        };
        std::deque<Item> queue{{root, 0}};
        // About one node per 7.6 triangles, one leaf index per triangle (the 871k dragon):
        // room reserved so that nodes of 224 bytes are not copied as the arrays grow.
        nodes.reserve(bin[root].below / 6 + 1);
        leaf_indices.reserve(bin[root].below);
        while (!queue.empty()) {
            const Item it = queue.front();
            queue.pop_front();
            stats.max_depth = std::max(stats.max_depth, it.depth);
            for (uint32_t b : make_node(it.bin)) queue.push_back({b, it.depth + 1});
        }
        finish_stats();
    }

    // The next wide node of `nodes` (breadth first: nodes are made in the order their indices
    // were handed out) from binary node b; its internal children get the next indices and are
    // returned, its leaves' triangles go to leaf_indices.
    Kids make_node(uint32_t b) {
        // (Fixed arrays: no allocation per node.)
        Kids kids = collapse(b);
        int slot_of[BVH_WIDTH];
        assign_slots(b, kids, slot_of);
        int kid_in_slot[BVH_WIDTH];
        std::fill(kid_in_slot, kid_in_slot + BVH_WIDTH, -1);
        for (size_t k = 0; k < kids.size(); ++k) kid_in_slot[slot_of[k]] = int(k);
        gpu::BvhNode out;
        std::memset(&out, 0, sizeof out);
        out.words[4] = allocated;
        out.words[5] = uint32_t(leaf_indices.size());
        // Internal children first (their indices), then the leaves' triangles.
        uint32_t imask = 0;
        Kids internal;
        for (int s = 0; s < int(BVH_WIDTH); ++s) {
            if (kid_in_slot[s] < 0) continue;
            const BinNode& c = bin[kids[size_t(kid_in_slot[s])]];
            uint32_t meta;
            if (!is_leaf(kids[size_t(kid_in_slot[s])])) {
                imask |= 1u << s;
                meta = (1u << 5) | uint32_t(24 + s);
                internal.push_back(kids[size_t(kid_in_slot[s])]);
            } else {
                const uint32_t offset = uint32_t(leaf_indices.size()) - out.words[5];
                meta = (((1u << c.below) - 1u) << 5) | offset;
                for (uint32_t i = 0; i < c.below; ++i)
                    leaf_indices.push_back(refs[c.first + i].tri);
                stats.leaves += 1;
            }
            put_byte(out.words[6 + s / 4], s % 4, meta);
        }
        quantize(out, kids, kid_in_slot, imask);
        nodes.push_back(out);
        allocated += uint32_t(internal.size());
        return internal;
    }

    void finish_stats() {
        stats.nodes = allocated;
        stats.references = leaf_indices.size();
        stats.mean_leaf_size = stats.leaves ? double(stats.references) / double(stats.leaves) : 0;
        stats.bytes = size_t(allocated) * sizeof(gpu::BvhNode) + leaf_indices.size() * 4;
    }

    // A child: a leaf when its subtree holds at most BVH_LEAF_MAX triangles (one slot
    // instead of a node of small leaves).
    bool is_leaf(uint32_t b) const { return bin[b].below <= BVH_LEAF_MAX; }

    // The children of the wide node made from binary node b: largest area opened first.
    Kids collapse(uint32_t b) const {
        Kids kids;
        if (is_leaf(b)) {  // a leaf root (at most BVH_LEAF_MAX triangles)
            kids.push_back(b);
            return kids;
        }
        if (plan) {
            plan->choose(b, kids);
            return kids;
        }
        // Each child's area once (-1 for a leaf: never opened).
        double area[BVH_WIDTH];
        const auto take = [&](size_t k, uint32_t c) {
            kids[k] = c;
            area[k] = is_leaf(c) ? -1.0 : half_area(bin[c].lo, bin[c].hi);
        };
        kids.n = 2;
        take(0, bin[b].left), take(1, bin[b].right);
        while (kids.size() < BVH_WIDTH) {
            int best = -1;
            double best_area = -1;
            for (size_t k = 0; k < kids.size(); ++k)
                if (area[k] >= 0 && area[k] > best_area) best = int(k), best_area = area[k];
            if (best < 0) break;
            const BinNode& c = bin[kids[size_t(best)]];
            kids.n += 1;
            take(kids.size() - 1, c.right);
            take(size_t(best), c.left);
        }
        return kids;
    }

    // Slot of each child: greedily, the (child, slot) pair with the child nearest along the
    // slot's octant direction first.
    void assign_slots(uint32_t b, const Kids& kids, int slot_of[BVH_WIDTH]) const {
        // Leaves only: slots 0, 1, ... in order. A leaf's triangles are taken by their offsets
        // whatever the ray's octant, so its slot does not matter, and a node of at most four
        // leaves has them in the first half, which the traversal tests alone.
        if (std::all_of(kids.begin(), kids.end(), [&](uint32_t k) { return is_leaf(k); })) {
            for (size_t k = 0; k < kids.size(); ++k) slot_of[k] = int(k);
            return;
        }
        const BinNode& parent = bin[b];
        float centre[3];
        for (int a = 0; a < 3; ++a) centre[a] = 0.5f * (parent.lo[a] + parent.hi[a]);
        float cost[BVH_WIDTH][BVH_WIDTH];
        for (size_t k = 0; k < kids.size(); ++k) {
            const BinNode& c = bin[kids[k]];
            for (int s = 0; s < int(BVH_WIDTH); ++s) {
                float d = 0;
                for (int a = 0; a < 3; ++a) {
                    const float sign = (s >> (2 - a)) & 1 ? -1.f : 1.f;
                    d += sign * (0.5f * (c.lo[a] + c.hi[a]) - centre[a]);
                }
                cost[k][s] = d;
            }
        }
        std::fill(slot_of, slot_of + BVH_WIDTH, -1);
        bool slot_used[BVH_WIDTH] = {};
        for (size_t round = 0; round < kids.size(); ++round) {
            int bk = -1, bs = -1;
            for (size_t k = 0; k < kids.size(); ++k) {
                if (slot_of[k] >= 0) continue;
                for (int s = 0; s < int(BVH_WIDTH); ++s)
                    if (!slot_used[s] && (bk < 0 || cost[k][s] < cost[bk][bs])) bk = int(k), bs = s;
            }
            slot_of[size_t(bk)] = bs;
            slot_used[bs] = true;
        }
    }

    void quantize(gpu::BvhNode& out, const Kids& kids, const int kid_in_slot[BVH_WIDTH],
                  uint32_t imask) const {
        float lo[3], hi[3];
        for (int a = 0; a < 3; ++a) {
            lo[a] = std::numeric_limits<float>::max(), hi[a] = -std::numeric_limits<float>::max();
            for (uint32_t k : kids)
                lo[a] = std::min(lo[a], bin[k].lo[a]), hi[a] = std::max(hi[a], bin[k].hi[a]);
        }
        uint32_t exps = 0;
        for (int a = 0; a < 3; ++a) {
            const AxisGrid g = axis_grid(lo[a], hi[a]);
            std::memcpy(&out.words[a], &g.p, 4);
            exps |= uint32_t(g.e + 127) << (8 * a);
            for (int s = 0; s < int(BVH_WIDTH); ++s) {
                if (kid_in_slot[s] < 0) continue;
                const BinNode& c = bin[kids[size_t(kid_in_slot[s])]];
                const double qlo = grid_below(c.lo[a], g), qhi = grid_above(c.hi[a], g);
                out.words[plane_word(a, false, s)] = plane_bits(grid_byte(qlo), g.e);
                out.words[plane_word(a, true, s)] = plane_bits(grid_byte(qhi), g.e);
            }
        }
        out.words[3] = exps | (imask << 24);
    }
};

// The wide tree: its root here, then the subtrees of the root's internal children each
// collapsed on its own (on up to `threads` threads; the collapse was a third of the 871k
// dragon's build on one), laid out as [root, the children's roots, the rest of child 0's
// subtree, of child 1's, ...] and their indices moved there, into `units` (the tree's 8-byte
// units). The same tree on any number of threads.
Collapser collapse_wide(const std::vector<BinNode>& bin, const std::vector<Prim>& refs, int threads,
                        std::vector<gpu::KdNode>& units, const CollapsePlan* plan) {
    Collapser top{bin, refs, {}, {}, {}, 1, plan};
    const Kids internal = top.make_node(0);
    std::vector<Collapser> subs;
    for (size_t j = 0; j < internal.size(); ++j)
        subs.push_back(Collapser{bin, refs, {}, {}, {}, 1, plan});
    // Largest subtrees first, each taken by the next free thread.
    std::vector<size_t> order(internal.size());
    for (size_t j = 0; j < order.size(); ++j) order[j] = j;
    std::sort(order.begin(), order.end(),
              [&](size_t a, size_t b) { return bin[internal[a]].below > bin[internal[b]].below; });
    std::atomic<size_t> next{0};
    const auto work = [&](size_t, size_t) {
        for (size_t k; (k = next.fetch_add(1)) < order.size();)
            subs[order[k]].run(internal[order[k]]);
    };
    const size_t workers =
        std::min<size_t>(std::max(threads, 1), std::max<size_t>(order.size(), 1));
    for_ranges(workers, work, 1);
    // Child j's root goes to 1 + j, its other nodes i to base_j + i - 1; its leaf indices
    // after those before it. Written straight into the tree's units, each subtree on a thread
    // (nodes of 224 bytes: a copy of the 871k dragon's tree is 25 MB).
    const size_t count = subs.size();
    std::vector<size_t> base(count), leaf_base(count);
    size_t nodes = 1 + count, leaves = top.leaf_indices.size();
    for (size_t j = 0; j < count; ++j) {
        base[j] = nodes, nodes += subs[j].allocated - 1;
        leaf_base[j] = leaves, leaves += subs[j].leaf_indices.size();
        top.stats.leaves += subs[j].stats.leaves;
        top.stats.max_depth = std::max(top.stats.max_depth, subs[j].stats.max_depth + 1);
    }
    units.resize(nodes * BVH_NODE_UNITS);
    std::memcpy(units.data(), &top.nodes[0], sizeof(gpu::BvhNode));
    top.leaf_indices.resize(leaves);
    std::atomic<size_t> next_copy{0};
    const auto copy = [&](size_t, size_t) {
        for (size_t j; (j = next_copy.fetch_add(1)) < count;) {
            const Collapser& c = subs[j];
            const uint32_t node_shift = uint32_t(base[j] - 1), leaf_shift = uint32_t(leaf_base[j]);
            for (size_t i = 0; i < c.nodes.size(); ++i) {
                gpu::BvhNode n = c.nodes[i];
                n.words[4] += node_shift;  // first child: never a subtree's root (index 0)
                n.words[5] += leaf_shift;
                const size_t at = i == 0 ? 1 + j : base[j] + i - 1;
                std::memcpy(units.data() + at * BVH_NODE_UNITS, &n, sizeof n);
            }
            std::copy(c.leaf_indices.begin(), c.leaf_indices.end(),
                      top.leaf_indices.begin() + std::ptrdiff_t(leaf_base[j]));
        }
    };
    for_ranges(workers, copy, 1);
    top.allocated = uint32_t(nodes);  // (for the stats; the nodes are in `units`)
    top.finish_stats();
    return top;
}

}  // namespace

KdTree build_wide_bvh(const std::vector<Triangle>& triangles, const TreeOptions& options) {
    const auto start = std::chrono::steady_clock::now();
    if (triangles.size() >= (size_t(1) << 30))
        throw Error("too many triangles for the BVH (at most 2^30 - 1)");
    KdTree tree;
    tree.kind = TreeKind::Bvh;
    // Finite triangles only (as the k-d tree: one with a NaN or infinite corner is never hit).
    std::vector<Prim> refs;
    refs.reserve(triangles.size());
    Boxes root;  // the references' boxes (the binary root's), gathered here: no pass of its own
    root.clear();
    for (size_t i = 0; i < triangles.size(); ++i) {
        const Triangle& t = triangles[i];
        bool finite = true;
        for (const glm::vec3& v : {t.v0, t.v1, t.v2})
            finite = finite && std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z);
        if (!finite) continue;
        const glm::vec3 lo = glm::min(t.v0, glm::min(t.v1, t.v2));
        const glm::vec3 hi = glm::max(t.v0, glm::max(t.v1, t.v2));
        refs.push_back({{lo.x, lo.y, lo.z}, {hi.x, hi.y, hi.z}, uint32_t(i)});
        tree.bounds.extend(lo), tree.bounds.extend(hi);
        root.add(refs.back());
    }
    root.known = true;
    const int threads = options.threads > 0 ? options.threads : int(usable_cpus());
    std::vector<BinNode> bin;
    if (refs.empty()) {
        // No triangle: a root without children.
        tree.nodes.resize(BVH_NODE_UNITS);
        tree.stats.nodes = 1;
        tree.stats.bytes = sizeof(gpu::BvhNode);
    } else {
        bin.reserve(refs.size());
        BinaryBuilder{refs}.build(0, uint32_t(refs.size()), bin, threads, root);
        std::unique_ptr<CollapsePlan> plan;
        if (options.bvh_optimal_collapse)
            plan = std::make_unique<CollapsePlan>(bin, kCollapseNodeCost, kCollapseTriangleCost);
        Collapser col = collapse_wide(bin, refs, threads, tree.nodes, plan.get());
        tree.leaf_indices = std::move(col.leaf_indices);
        tree.stats = col.stats;
    }
    tree.stats.threads = threads;
    tree.stats.build_seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    return tree;
}

uint32_t bvh_node_count(const KdTree& tree) {
    return uint32_t(tree.nodes.size() / BVH_NODE_UNITS);
}

gpu::BvhNode bvh_node(const KdTree& tree, uint32_t i) {
    gpu::BvhNode n;
    std::memcpy(&n, tree.nodes.data() + size_t(i) * BVH_NODE_UNITS, sizeof n);
    return n;
}

void set_bvh_node(KdTree& tree, uint32_t i, const gpu::BvhNode& node) {
    std::memcpy(tree.nodes.data() + size_t(i) * BVH_NODE_UNITS, &node, sizeof node);
}

// A node's grid exponent on an axis.
static int grid_exponent(const gpu::BvhNode& node, int axis) {
    return int(get_byte(node.words[3], axis)) - 127;
}

uint32_t bvh_plane(const gpu::BvhNode& node, int axis, bool high, int slot) {
    float d;
    std::memcpy(&d, &node.words[plane_word(axis, high, slot)], 4);
    return grid_byte(std::ldexp(double(d), -grid_exponent(node, axis)));  // (an infinite one: 255)
}

void set_bvh_plane(gpu::BvhNode& node, int axis, bool high, int slot, uint32_t q) {
    node.words[plane_word(axis, high, slot)] = plane_bits(q, grid_exponent(node, axis));
}

std::vector<BvhChild> bvh_children(const gpu::BvhNode& n) {
    std::vector<BvhChild> out;
    const uint32_t imask = n.words[3] >> 24;
    for (int s = 0; s < int(BVH_WIDTH); ++s) {
        const uint32_t meta = get_byte(n.words[6 + s / 4], s % 4);
        if (meta == 0) continue;
        BvhChild c;
        c.slot = s;
        c.internal = (imask >> s) & 1u;
        if (c.internal) {
            c.index = n.words[4] + uint32_t(__builtin_popcount(imask & ((1u << s) - 1u)));
        } else {
            c.index = n.words[5] + (meta & 31u);
            c.triangles = uint32_t(__builtin_popcount(meta >> 5));
        }
        for (int a = 0; a < 3; ++a) {
            float p, lo, hi;
            std::memcpy(&p, &n.words[a], 4);
            std::memcpy(&lo, &n.words[plane_word(a, false, s)], 4);
            std::memcpy(&hi, &n.words[plane_word(a, true, s)], 4);
            c.lo[a] = double(p) + lo;
            c.hi[a] = double(p) + hi;
        }
        out.push_back(c);
    }
    return out;
}

double bvh_sah_cost(const KdTree& tree, double node, double triangle) {
    const float lo[3] = {tree.bounds.min.x, tree.bounds.min.y, tree.bounds.min.z};
    const float hi[3] = {tree.bounds.max.x, tree.bounds.max.y, tree.bounds.max.z};
    const double root = half_area(lo, hi);
    if (tree.leaf_indices.empty() || !(root > 0)) return 0;
    double cost = 0;
    for (uint32_t i = 0; i < bvh_node_count(tree); ++i)
        for (const BvhChild& c : bvh_children(bvh_node(tree, i)))
            cost += half_area(c.lo, c.hi) * (c.internal ? node : triangle * c.triangles);
    return cost / root;
}

}  // namespace mcpt
