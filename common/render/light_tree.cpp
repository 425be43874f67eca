#include "common/render/light_tree.h"

#include <algorithm>
#include <cmath>
#include <numeric>

#include "common/error.h"

namespace mcpt {

DirectionCone cone_union(const DirectionCone& a, const DirectionCone& b) {
    const DirectionCone everywhere{};
    if (a.cos_theta <= -1.f || b.cos_theta <= -1.f) return everywhere;
    // In double precision: angles of a and b, and between their axes.
    const auto angle = [](double c) { return std::acos(std::clamp(c, -1.0, 1.0)); };
    const glm::dvec3 wa(a.axis), wb(b.axis);
    const double ta = angle(a.cos_theta), tb = angle(b.cos_theta);
    const double td = angle(glm::dot(wa, wb));
    // One holds the other.
    if (std::min(td + tb, M_PI) <= ta) return a;
    if (std::min(td + ta, M_PI) <= tb) return b;
    // The cone from a's far edge to b's: its axis a's turned towards b's by to - ta.
    const double to = 0.5 * (ta + td + tb);
    if (to >= M_PI) return everywhere;
    const glm::dvec3 normal = glm::cross(wa, wb);
    const double len = glm::length(normal);
    if (len < 1e-12) return everywhere;
    const glm::dvec3 k = normal / len;
    const double r = to - ta;
    // Rodrigues' rotation of wa about k by r (k is perpendicular to wa).
    const glm::dvec3 w = wa * std::cos(r) + glm::cross(k, wa) * std::sin(r);
    // A microradian for the axis' rounding to float; the cosine rounded down (near 1 a float
    // cosine steps by 3.5e-4 rad).
    const double cos_o = std::cos(std::min(M_PI, to + 1e-6));
    float c = float(cos_o);
    if (double(c) > cos_o) c = std::nextafter(c, -1.f);
    return {glm::vec3(glm::normalize(w)), c};
}

namespace {

struct Builder {
    const std::vector<TreeLight>& lights;
    LightTree& tree;

    // Fills node `at` with lights [first, last) of `order`; `trail` and `depth` lead to it.
    void build(std::vector<uint32_t>& order, size_t first, size_t last, size_t at, uint32_t trail,
               int depth) {
        tree.depth = std::max(tree.depth, depth);
        glm::vec3 lo(HUGE_VALF), hi(-HUGE_VALF), clo(HUGE_VALF), chi(-HUGE_VALF);
        double power = 0;
        DirectionCone cone;
        for (size_t i = first; i < last; ++i) {
            const TreeLight& l = lights[order[i]];
            lo = glm::min(lo, l.lo), hi = glm::max(hi, l.hi);
            const glm::vec3 c = 0.5f * (l.lo + l.hi);
            clo = glm::min(clo, c), chi = glm::max(chi, c);
            power += l.power;
            const DirectionCone own{l.axis, l.cos_o};
            cone = i == first ? own : cone_union(cone, own);
        }
        gpu::GpuLightTreeNode& n = tree.nodes[at];
        n.min_x = lo.x, n.min_y = lo.y, n.min_z = lo.z;
        n.max_x = hi.x, n.max_y = hi.y, n.max_z = hi.z;
        n.power = float(power);
        n.axis_x = cone.axis.x, n.axis_y = cone.axis.y, n.axis_z = cone.axis.z;
        n.cos_o = cone.cos_theta;
        if (last - first == 1) {
            n.child = LIGHT_TREE_LEAF | lights[order[first]].slot;
            tree.trails[order[first]] = trail;
            return;
        }
        if (depth >= 32) throw Error("light tree deeper than 32 levels");
        // The median along the widest extent of the centroids.
        const glm::vec3 e = chi - clo;
        const int axis = e.x >= e.y && e.x >= e.z ? 0 : (e.y >= e.z ? 1 : 2);
        const size_t mid = first + (last - first) / 2;
        std::nth_element(order.begin() + long(first), order.begin() + long(mid),
                         order.begin() + long(last), [&](uint32_t a, uint32_t b) {
                             const float ca = lights[a].lo[axis] + lights[a].hi[axis];
                             const float cb = lights[b].lo[axis] + lights[b].hi[axis];
                             return ca < cb || (ca == cb && a < b);
                         });
        const size_t child = tree.nodes.size();
        tree.nodes.resize(child + 2);
        tree.nodes[at].child = uint32_t(child);
        build(order, first, mid, child, trail, depth + 1);
        build(order, mid, last, child + 1, trail | (1u << depth), depth + 1);
    }
};

}  // namespace

LightTree build_light_tree(const std::vector<TreeLight>& lights) {
    LightTree tree;
    if (lights.empty()) return tree;
    tree.trails.assign(lights.size(), 0);
    tree.nodes.resize(1);
    tree.nodes.reserve(2 * lights.size());
    std::vector<uint32_t> order(lights.size());
    std::iota(order.begin(), order.end(), 0u);
    Builder{lights, tree}.build(order, 0, lights.size(), 0, 0u, 0);
    return tree;
}

}  // namespace mcpt
