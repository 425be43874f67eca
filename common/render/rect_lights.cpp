#include "common/render/rect_lights.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <map>
#include <tuple>

namespace mcpt {

namespace {

constexpr double kRightCos = 1e-5;   // |cos| at the right angle, at most
constexpr double kAcuteCos = 1e-3;   // |cos| at the two others, at least (unambiguous corner)
constexpr double kCornerTol = 1e-5;  // the fourth corner's miss, over the hypotenuse's length

// A triangle as half of a rectangle: its right-angle vertex and the hypotenuse's two.
struct RightTriangle {
    int corner = -1;  // 0, 1 or 2; -1: no right angle
    glm::dvec3 c, p, q;
};

RightTriangle right_angle_of(const Triangle& t) {
    const glm::dvec3 v[3] = {glm::dvec3(t.v0), glm::dvec3(t.v1), glm::dvec3(t.v2)};
    RightTriangle r;
    double cosines[3];
    for (int k = 0; k < 3; ++k) {
        const glm::dvec3 a = v[(k + 1) % 3] - v[k], b = v[(k + 2) % 3] - v[k];
        const double la = glm::length(a), lb = glm::length(b);
        if (!(la > 0 && lb > 0)) return r;
        cosines[k] = std::abs(glm::dot(a, b)) / (la * lb);
    }
    for (int k = 0; k < 3; ++k) {
        if (cosines[k] <= kRightCos && cosines[(k + 1) % 3] >= kAcuteCos &&
            cosines[(k + 2) % 3] >= kAcuteCos) {
            r.corner = k;
            r.c = v[k], r.p = v[(k + 1) % 3], r.q = v[(k + 2) % 3];
        }
    }
    return r;
}

// A vertex as its bits: shared vertices of a mesh are the same floats.
std::tuple<uint32_t, uint32_t, uint32_t> bits_of(glm::vec3 v) {
    uint32_t b[3];
    std::memcpy(b, &v, sizeof b);
    return {b[0], b[1], b[2]};
}

glm::vec3 vertex(const Triangle& t, int k) {
    return k == 0 ? t.v0 : k == 1 ? t.v1 : t.v2;
}

}  // namespace

std::vector<RectPair> find_rect_lights(const Scene& scene) {
    // Emissive right triangles by (material, hypotenuse).
    using Key = std::tuple<uint32_t, std::tuple<uint32_t, uint32_t, uint32_t>,
                           std::tuple<uint32_t, uint32_t, uint32_t>>;
    std::map<Key, std::vector<uint32_t>> by_hypotenuse;
    std::vector<RightTriangle> right(scene.triangles.size());
    for (size_t i = 0; i < scene.triangles.size(); ++i) {
        const Triangle& t = scene.triangles[i];
        const Material& m = scene.materials.at(t.material);
        if (!m.is_emissive() || m.tex_emission >= 0) continue;
        right[i] = right_angle_of(t);
        if (right[i].corner < 0) continue;
        auto a = bits_of(vertex(t, (right[i].corner + 1) % 3));
        auto b = bits_of(vertex(t, (right[i].corner + 2) % 3));
        if (b < a) std::swap(a, b);
        by_hypotenuse[{t.material, a, b}].push_back(uint32_t(i));
    }
    std::vector<RectPair> pairs;
    for (const auto& [key, tris] : by_hypotenuse) {
        if (tris.size() != 2) continue;  // (more than two on one edge: no rectangle)
        const RightTriangle &a = right[tris[0]], &b = right[tris[1]];
        // The corners opposite across the hypotenuse, and the faces turned the same way.
        const glm::dvec3 fourth = a.p + a.q - a.c;
        const double hyp = glm::length(a.q - a.p);
        if (!(glm::length(fourth - b.c) <= kCornerTol * hyp)) continue;
        const Triangle &ta = scene.triangles[tris[0]], &tb = scene.triangles[tris[1]];
        const glm::dvec3 na = glm::cross(glm::dvec3(ta.v1 - ta.v0), glm::dvec3(ta.v2 - ta.v0));
        const glm::dvec3 nb = glm::cross(glm::dvec3(tb.v1 - tb.v0), glm::dvec3(tb.v2 - tb.v0));
        if (!(glm::dot(na, nb) > 0)) continue;
        pairs.push_back({std::min(tris[0], tris[1]), std::max(tris[0], tris[1])});
    }
    std::sort(pairs.begin(), pairs.end(),
              [](const RectPair& x, const RectPair& y) { return x.head < y.head; });
    return pairs;
}

RectLights::RectLights(const std::vector<RectPair>& pairs, size_t triangles)
    : partner_(triangles, kNoPartner), head_(triangles, kNoPartner), count_(pairs.size()) {
    for (const RectPair& p : pairs) partner_.at(p.head) = p.partner, head_.at(p.partner) = p.head;
}

}  // namespace mcpt
