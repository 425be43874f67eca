// The k-d tree's split rules (kdtree_split.h): the SAH's binned and exact searches, and the
// median split. The search's design is in kdtree.cpp's opening comment.
#include "common/accel/kdtree_split.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>

namespace mcpt::kdbuild {

namespace {

constexpr size_t kExactMax = 16;   // nodes with at most this many references sweep exactly
constexpr int kBins = 64;          // bins per axis for larger nodes, at most
constexpr int kMinBins = 8;        // ... and at least
constexpr size_t kRefsPerBin = 2;  // ... and one bin per this many references

// Sortable key of a float: unsigned order equals float order (-0 is folded into +0 first).
uint32_t float_key(float f) {
    f += 0.0f;
    uint32_t u;
    std::memcpy(&u, &f, 4);
    return (u & 0x80000000u) ? ~u : (u | 0x80000000u);
}

float key_float(uint32_t k) {
    uint32_t u = (k & 0x80000000u) ? (k & 0x7fffffffu) : ~k;
    float f;
    std::memcpy(&f, &u, 4);
    return f;
}

// pbrt-v3 SAH cost of splitting `box` at `pos` on `axis` with nb/na references below/above.
// Areas in units of `scale` (a power of two, 1 unless a node's area overflows float: beyond
// extents of about 1e19, where an infinite area priced every split at the traversal cost
// alone).
struct SahCost {
    const TreeOptions& opt;
    const Box& box;
    float inv_total_sa;
    float d[3];
    float scale = 1.f;
    float operator()(int axis, float pos, size_t nb, size_t na) const {
        const int o0 = (axis + 1) % 3, o1 = (axis + 2) % 3;
        const float face = d[o0] * d[o1], rim = d[o0] + d[o1];
        const float below = pos * scale - box.lo[axis] * scale;
        const float above = box.hi[axis] * scale - pos * scale;
        const float p_below = 2.f * (face + below * rim) * inv_total_sa;
        const float p_above = 2.f * (face + above * rim) * inv_total_sa;
        const float bonus = (nb == 0 || na == 0) ? opt.empty_bonus : 0.f;
        return opt.traversal_cost +
               opt.isect_cost * (1.f - bonus) * (p_below * float(nb) + p_above * float(na));
    }
};

struct Candidate {
    int axis = -1;
    float pos = 0.f;
    float cost = std::numeric_limits<float>::infinity();
    void offer(int a, float p, float c) {
        if (c < cost) axis = a, pos = p, cost = c;
    }
    void offer(const Candidate& c) {
        if (c.cost < cost) *this = c;
    }
};

enum : uint64_t { kEnd = 0, kPlanar = 1, kStart = 2 };  // event order at one position

// Adds the events of a reference on axis a that fall in [w0, w1] (Wald & Havran: a flat
// reference gives one planar event, others a start and an end).
inline void add_events(const Ref& r, int a, float w0, float w1, std::vector<uint64_t>& events) {
    const float lo = r.lo[a], hi = r.hi[a];
    if (lo == hi) {
        if (lo >= w0 && lo <= w1) events.push_back(uint64_t(float_key(lo)) << 2 | kPlanar);
        return;
    }
    if (lo >= w0 && lo <= w1) events.push_back(uint64_t(float_key(lo)) << 2 | kStart);
    if (hi >= w0 && hi <= w1) events.push_back(uint64_t(float_key(hi)) << 2 | kEnd);
}

// Sorts the events of axis a and sweeps every position: `below` references start before
// the first event, `above` end after it; flat references in the plane count on both sides.
void sweep(std::vector<uint64_t>& events, int a, size_t below, size_t above, const SahCost& sah,
           Candidate& best) {
    std::sort(events.begin(), events.end());
    for (size_t i = 0; i < events.size();) {
        const uint64_t key = events[i] >> 2;
        size_t ends = 0, planar = 0, starts = 0;
        for (; i < events.size() && (events[i] >> 2) == key; ++i) {
            const uint64_t type = events[i] & 3u;
            ends += type == kEnd, planar += type == kPlanar, starts += type == kStart;
        }
        above -= ends + planar;
        const float pos = key_float(uint32_t(key));
        if (pos > sah.box.lo[a] && pos < sah.box.hi[a]) {
            best.offer(a, pos, sah(a, pos, below + planar, above + planar));
        }
        below += starts + planar;
    }
}

// Exact SAH for small nodes: every event position on every axis.
void exact_search(const Ref* refs, size_t n, const SahCost& sah, Candidate& best,
                  std::vector<uint64_t>& events) {
    const float inf = std::numeric_limits<float>::infinity();
    for (int a = 0; a < 3; ++a) {
        if (!(sah.d[a] > 0.f)) continue;
        events.clear();
        for (size_t i = 0; i < n; ++i) add_events(refs[i], a, -inf, inf, events);
        sweep(events, a, 0, n, sah, best);
    }
}

// Binned SAH for large nodes: bins span the references' union, so its ends are exact
// empty-space cuts; the best boundary is then refined by an exact sweep over
// the events of the two bins around the best one.
void binned_search(const Ref* refs, size_t n, const Box& refs_union, const SahCost& sah,
                   Candidate& best, std::vector<uint64_t>& events) {
    const Box& box = sah.box;
    const float* ulo = refs_union.lo;
    const float* uhi = refs_union.hi;
    // Count bounds into bins over the union.
    const int bins = int(std::clamp<size_t>(n / kRefsPerBin, kMinBins, kBins));
    uint32_t starts[3][kBins], ends[3][kBins];
    std::memset(starts, 0, sizeof starts), std::memset(ends, 0, sizeof ends);
    float scale[3], width[3];
    for (int a = 0; a < 3; ++a) {
        width[a] = (uhi[a] - ulo[a]) / float(bins);
        scale[a] = uhi[a] > ulo[a] ? float(bins) / (uhi[a] - ulo[a]) : 0.f;
    }
    // References lie in the union, but over a denormal-thin union the scale overflows to inf
    // (and 0 * inf is NaN): clamp in float, then convert.
    const int last = bins - 1;
    const auto bin = [&](float x, int a) {
        const float f = (x - ulo[a]) * scale[a];
        return f >= float(last) ? last : f > 0.f ? int(f) : 0;
    };
    for (size_t i = 0; i < n; ++i) {
        const Ref& r = refs[i];
        ++starts[0][bin(r.lo[0], 0)], ++ends[0][bin(r.hi[0], 0)];
        ++starts[1][bin(r.lo[1], 1)], ++ends[1][bin(r.hi[1], 1)];
        ++starts[2][bin(r.lo[2], 2)], ++ends[2][bin(r.hi[2], 2)];
    }
    // Sweep the bin boundaries, union ends included.
    int best_bin[3] = {-1, -1, -1};
    for (int a = 0; a < 3; ++a) {
        if (!(uhi[a] > ulo[a])) continue;
        Candidate axis_best;
        size_t below = 0, ended = 0;
        for (int i = 0; i <= bins; ++i) {
            if (i > 0) below += starts[a][i - 1], ended += ends[a][i - 1];
            const float pos = i == bins ? uhi[a] : ulo[a] + width[a] * float(i);
            if (!(pos > box.lo[a] && pos < box.hi[a])) continue;
            const float cost = sah(a, pos, below, n - ended);
            if (cost < axis_best.cost) best_bin[a] = i;
            axis_best.offer(a, pos, cost);
        }
        best.offer(axis_best);
    }
    // Exact sweep within the two bins around the best boundary.
    if (best.axis >= 0 && best_bin[best.axis] > 0 && best_bin[best.axis] < bins) {
        const int a = best.axis, i = best_bin[a];
        const float w0 = ulo[a] + width[a] * float(i - 1), w1 = ulo[a] + width[a] * float(i + 1);
        size_t below = 0, ended = 0;
        events.clear();
        for (size_t k = 0; k < n; ++k) {
            const float lo = refs[k].lo[a], hi = refs[k].hi[a];
            below += lo < w0;
            ended += hi < w0;
            if (hi >= w0 && lo <= w1) add_events(refs[k], a, w0, w1, events);
        }
        sweep(events, a, below, n - ended, sah, best);
    }
}

// The median rule: the median triangle centroid on axes in turn, to exactly max_depth levels.
class MedianRule : public SplitRule {
  public:
    MedianRule(const std::vector<Triangle>& tris, int max_depth)
        : tris_(tris), max_depth_(max_depth) {}

    Split choose(const Ref* refs, size_t n, const Box&, const Box&, int depth, int,
                 Scratch& scratch) const override {
        Split split;
        if (n <= 1 || depth >= max_depth_) return split;
        const int a = depth % 3;
        std::vector<float>& c = scratch.keys;
        c.resize(n);
        for (size_t i = 0; i < n; ++i) {
            const Triangle& t = tris_[refs[i].tri];
            c[i] = (t.v0[a] + t.v1[a] + t.v2[a]) * (1.f / 3.f);
        }
        std::nth_element(c.begin(), c.begin() + ptrdiff_t(n / 2), c.end());
        split.axis = a;
        split.pos = c[n / 2];
        return split;
    }

  private:
    const std::vector<Triangle>& tris_;
    int max_depth_;
};

class SahRule : public SplitRule {
  public:
    SahRule(const TreeOptions& opt, int max_depth) : opt_(opt), max_depth_(max_depth) {}

    Split choose(const Ref* refs, size_t n, const Box& box, const Box& refs_union, int depth,
                 int bad_refines, Scratch& scratch) const override {
        Split leaf;
        if (n <= size_t(std::max(opt_.max_leaf_prims, 0)) || depth >= max_depth_ || n == 0) {
            return leaf;
        }
        // Node surface area; a node flat in two axes cannot be split usefully.
        SahCost sah{opt_, box, 0.f, {}};
        const auto area = [&] {
            for (int a = 0; a < 3; ++a) sah.d[a] = box.hi[a] * sah.scale - box.lo[a] * sah.scale;
            return 2.f * (sah.d[0] * sah.d[1] + sah.d[1] * sah.d[2] + sah.d[2] * sah.d[0]);
        };
        float total_sa = area();
        if (total_sa == std::numeric_limits<float>::infinity()) {
            sah.scale = 0x1p-70f;  // exact; extents (< 2^129) then square within float
            total_sa = area();
        }
        if (!(total_sa > 0.f) || !std::isfinite(total_sa)) return leaf;
        sah.inv_total_sa = 1.f / total_sa;
        // Best split over the three axes.
        Candidate best;
        if (n > kExactMax) {
            binned_search(refs, n, refs_union, sah, best, scratch.events);
        } else {
            exact_search(refs, n, sah, best, scratch.events);
        }
        // pbrt-v3 termination.
        const float leaf_cost = opt_.isect_cost * float(n);
        if (best.cost > leaf_cost) ++bad_refines;
        if ((best.cost > 4.f * leaf_cost && n < 16) || best.axis < 0 || bad_refines >= 3) {
            return leaf;
        }
        Split split;
        split.axis = best.axis;
        split.pos = best.pos;
        split.bad_refines = bad_refines;
        split.clip_exact = true;
        return split;
    }

  private:
    const TreeOptions& opt_;
    int max_depth_;
};

}  // namespace

std::unique_ptr<SplitRule> sah_rule(const TreeOptions& options, int max_depth) {
    return std::make_unique<SahRule>(options, max_depth);
}

std::unique_ptr<SplitRule> median_rule(const std::vector<Triangle>& triangles, int max_depth) {
    return std::make_unique<MedianRule>(triangles, max_depth);
}

}  // namespace mcpt::kdbuild
