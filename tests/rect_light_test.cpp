// Emissive rectangles sampled as spherical rectangles (common/gpu/rect_light.h, the device code
// compiled for the CPU; the host's pairing, common/render/rect_lights.cpp): the solid angle
// against quadrature of cos / d^2 over the rectangle, a chi-square of the sampled points
// against the solid-angle pdf from receivers near, far, grazing and behind (control: area
// sampling's points against the same pdf), the warp toward the receiver's cosine against its
// bilinear pdf, the rectangle found again from either half, the
// bounds where area sampling takes over, the same samples at scales 1e-3 to 1e4, and which
// triangle pairs the host takes for rectangles (and which it must not).
#include "common/gpu/rect_light.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "common/render/rect_lights.h"
#include "solid_angle_chi_square.h"

namespace mcpt {
namespace {

using glm::dvec3;
using glm::vec2;
using glm::vec3;

// A 1 x 0.6 light in the plane y = 1 (its corner at the origin's column), and receivers.
const vec3 kC(0.f, 1.f, 0.f), kEx(1.f, 0.f, 0.f), kEy(0.f, 0.f, 0.6f);
gpu::RectLight light() {
    gpu::RectLight r;
    r.c = kC, r.ex = kEx, r.ey = kEy;
    return r;
}

struct Receiver {
    std::string name;
    vec3 x;
};
std::vector<Receiver> receivers() {
    return {{"near, under the middle", vec3(0.5f, 0.95f, 0.3f)},
            {"near, beside an edge", vec3(1.1f, 0.92f, 0.3f)},
            {"under a corner", vec3(0.f, 0.7f, 0.f)},
            {"far below", vec3(0.3f, -1.5f, 0.2f)},
            {"grazing, 0.02 below the plane", vec3(-0.6f, 0.98f, 0.3f)},
            {"behind", vec3(0.4f, 1.3f, 0.2f)}};
}

// The solid angle of the part [sa, sb) x [ta, tb) of the rectangle at x: cos / d^2 over its
// area by the midpoint rule on n x n points.
double solid_angle_of(dvec3 x, double sa, double sb, double ta, double tb, int n) {
    const dvec3 c(kC), ex(kEx), ey(kEy);
    const double area = glm::length(glm::cross(ex, ey)) * (sb - sa) * (tb - ta);
    double sum = 0;
    for (int i = 0; i < n; ++i)
        for (int j = 0; j < n; ++j) {
            const dvec3 p =
                c + ex * (sa + (sb - sa) * (i + 0.5) / n) + ey * (ta + (tb - ta) * (j + 0.5) / n);
            const dvec3 d = p - x;
            const double d2 = glm::dot(d, d);
            sum += std::abs(d.y) / (d2 * std::sqrt(d2));
        }
    return sum * area / (double(n) * n);
}

TEST(RectLight, SolidAngleIsTheIntegralOfCosOverDistanceSquared) {
    for (const Receiver& r : receivers()) {
        const float omega = gpu::rect_solid_angle(NO_SCENE light(), r.x);
        const double quadrature = solid_angle_of(dvec3(r.x), 0, 1, 0, 1, 2000);
        std::printf("%-30s solid angle %.6f sr, quadrature %.6f\n", r.name.c_str(), omega,
                    quadrature);
        ASSERT_GT(omega, 0.f) << r.name << ": sampled by area";
        EXPECT_NEAR(omega / quadrature, 1.0, 2e-4) << r.name;
    }
}

TEST(RectLight, SampledDirectionsFollowTheSolidAnglePdf) {
    constexpr int kCells = 10, kSamples = 200000;
    for (const Receiver& r : receivers()) {
        const float omega = gpu::rect_solid_angle(NO_SCENE light(), r.x);
        ASSERT_GT(omega, 0.f) << r.name;
        // Per cell of (s, t): its solid angle over the whole.
        const auto [p, p_area] = test::solid_angle_chi_square(
            kCells, kSamples, omega, 13,
            [&](int i, int j) {
                return solid_angle_of(dvec3(r.x), double(i) / kCells, double(i + 1) / kCells,
                                      double(j) / kCells, double(j + 1) / kCells, 24);
            },
            [&](vec2 u, bool by_area) {
                const vec2 st = gpu::sample_rect_light(light(), r.x, by_area ? 0.f : omega, u);
                EXPECT_TRUE(std::isfinite(st.x) && std::isfinite(st.y) && st.x >= 0.f &&
                            st.y >= 0.f && st.x <= 1.f && st.y <= 1.f);
                return st;
            });
        std::printf("%-30s chi-square p = %.3f; control (by area): p = %.3g\n", r.name.c_str(), p,
                    p_area);
        EXPECT_GT(p, 1e-3) << r.name;
        EXPECT_LT(p_area, 1e-6) << r.name << ": area sampling passed the solid-angle pdf";
    }
}

// The warp toward the receiver's cosine (sampling.h: sample_bilinear, bilinear_pdf), with the
// weights the integrator gives the corners from each receiver (shading normal +y, toward the
// light, or -y behind it): a chi-square of the warped uniforms against each cell's integral of
// bilinear_pdf (closed form), and that pdf integrating to 1. Control: the warp mirrored in x
// (the weights of (0, 0) and (1, 0), (0, 1) and (1, 1) swapped) against the same pdf, where the
// weights vary by 20% or more (under the middle and far below they hardly do: the warp is near
// uniform there, and so is any mistake in it). (The spherical rectangle maps the warped
// uniforms on: SampledDirectionsFollowTheSolidAnglePdf.)
TEST(RectLight, CosineWarpFollowsItsBilinearPdf) {
    constexpr int kCells = 10, kSamples = 200000;
    const gpu::RectLight r = light();
    for (const Receiver& rec : receivers()) {
        const vec3 ns(0.f, rec.x.y < 1.f ? 1.f : -1.f, 0.f), c = r.c - rec.x;
        const glm::vec4 w(gpu::cosine_warp_weight(ns, c), gpu::cosine_warp_weight(ns, c + r.ex),
                          gpu::cosine_warp_weight(ns, c + r.ey),
                          gpu::cosine_warp_weight(ns, c + r.ex + r.ey));
        // The integral of bilinear_pdf over [xa, xb) x [ya, yb).
        const auto cell = [&](double xa, double xb, double ya, double yb) {
            const double x1 = (xb * xb - xa * xa) / 2, x0 = (xb - xa) - x1;
            const double y1 = (yb * yb - ya * ya) / 2, y0 = (yb - ya) - y1;
            return 4 * (w.x * x0 * y0 + w.y * x1 * y0 + w.z * x0 * y1 + w.w * x1 * y1) /
                   (double(w.x) + w.y + w.z + w.w);
        };
        double midpoint = 0;  // bilinear_pdf itself, by the midpoint rule
        for (int i = 0; i < 100; ++i)
            for (int j = 0; j < 100; ++j)
                midpoint += gpu::bilinear_pdf(vec2((i + 0.5f) / 100, (j + 0.5f) / 100), w) / 1e4;
        EXPECT_NEAR(midpoint, 1.0, 1e-4) << rec.name;
        const auto [p, p_mirrored] = test::solid_angle_chi_square(
            kCells, kSamples, 1.0, 17,
            [&](int i, int j) {
                return cell(double(i) / kCells, double(i + 1) / kCells, double(j) / kCells,
                            double(j + 1) / kCells);
            },
            [&](vec2 u, bool mirrored) {
                const vec2 q =
                    gpu::sample_bilinear(u, mirrored ? glm::vec4(w.y, w.x, w.w, w.z) : w);
                EXPECT_TRUE(q.x >= 0.f && q.y >= 0.f && q.x < 1.f && q.y < 1.f);
                return q;
            });
        std::printf(
            "%-30s weights %.3f %.3f %.3f %.3f: chi-square p = %.3f; control (mirrored): "
            "p = %.3g\n",
            rec.name.c_str(), w.x, w.y, w.z, w.w, p, p_mirrored);
        EXPECT_GT(p, 1e-3) << rec.name;
        const float spread = std::max({w.x, w.y, w.z, w.w}) / std::min({w.x, w.y, w.z, w.w});
        if (spread >= 1.2f) {
            EXPECT_LT(p_mirrored, 1e-6) << rec.name << ": the mirrored warp passed";
        }
    }
}

// Either half, whatever its winding and first vertex, gives the same rectangle back: the same
// area and the same four corners.
TEST(RectLight, EitherHalfGivesTheRectangle) {
    const vec3 a = kC, b = kC + kEx, d = kC + kEx + kEy, e = kC + kEy;
    const vec3 halves[][3] = {{a, b, d}, {a, d, e}, {d, a, b}, {e, d, a}, {b, a, d}, {a, e, d}};
    for (const auto& h : halves) {
        const gpu::RectLight r = gpu::rect_of_triangle(h[0], h[1], h[2]);
        EXPECT_NEAR(gpu::rect_area(r), 0.6f, 1e-6f);
        const vec3 corners[4] = {r.c, r.c + r.ex, r.c + r.ey, r.c + r.ex + r.ey};
        for (const vec3& want : {a, b, d, e}) {
            float nearest = 1e30f;
            for (const vec3& got : corners) nearest = std::min(nearest, glm::length(got - want));
            EXPECT_LT(nearest, 1e-6f);
        }
    }
}

// Where the solid angle is too small for float arithmetic or nearly a hemisphere, or the
// light is far for its size, the rectangle is sampled by area; samples stay inside either way.
TEST(RectLight, AreaSamplingTakesOverAtTheExtremes) {
    const auto scaled = [](float s) {
        gpu::RectLight r = light();
        r.c *= s, r.ex *= s, r.ey *= s;
        return r;
    };
    const struct {
        const char* what;
        gpu::RectLight r;
        vec3 x;
        bool by_area;
    } cases[] = {
        {"a receiver 1e-6 from the light's plane", light(), vec3(1.5f, 1.f - 1e-6f, 0.5f), true},
        {"a receiver in the light's plane", light(), vec3(1.5f, 1.f, 0.5f), true},
        {"a light of 1e-3 at 10", scaled(1e-3f), vec3(0.f, -10.f, 0.f), true},
        {"a light of 1e4 at 1e-2", scaled(1e4f), vec3(5e3f, 1e4f - 1e-2f, 3e3f), true},
        {"a receiver on a corner", light(), kC, true},
        {"a light far for its size", light(), vec3(0.5f, -4.f, 0.3f), true},
        {"a light of 1 at 0.5", light(), vec3(0.5f, 0.5f, 0.3f), false},
    };
    for (const auto& c : cases) {
        const float omega = gpu::rect_solid_angle(NO_SCENE c.r, c.x);
        EXPECT_EQ(omega == 0.f, c.by_area) << c.what << ": solid angle " << omega;
        for (const vec2 u : {vec2(0.f, 0.f), vec2(0.5f, 0.5f), vec2(0.99999994f, 0.99999994f),
                             vec2(0.f, 0.99999994f), vec2(0.99999994f, 0.f)}) {
            const vec2 st = gpu::sample_rect_light(c.r, c.x, omega, u);
            EXPECT_TRUE(std::isfinite(st.x) && std::isfinite(st.y) && st.x >= 0.f && st.y >= 0.f &&
                        st.x <= 1.f && st.y <= 1.f)
                << c.what << ": " << st.x << ", " << st.y;
        }
    }
    gpu::GpuParams by_area{};
    by_area.scene_flags = SCENE_TRIANGLE_LIGHTS_BY_AREA;
    EXPECT_EQ(gpu::rect_solid_angle(&by_area, nullptr, nullptr, nullptr, nullptr, nullptr, nullptr,
                                    nullptr, nullptr, nullptr, light(), vec3(0.5f, 0.5f, 0.3f)),
              0.f);
}

// The same light and receiver at scales 1e-3 to 1e4, and moved 1e3 away: the same solid angle
// and the same points for the same uniforms, to float precision.
TEST(RectLight, SameSamplesAtEveryScale) {
    const vec3 x(0.7f, 0.6f, 0.2f);
    const float omega1 = gpu::rect_solid_angle(NO_SCENE light(), x);
    ASSERT_GT(omega1, 0.f);
    for (const float scale : {1e-3f, 1e-1f, 1e2f, 1e4f})
        for (const float shift : {0.f, 1e3f}) {
            const vec3 t = vec3(shift, -shift, 0.5f * shift) * scale;
            gpu::RectLight r = light();
            r.c = r.c * scale + t, r.ex *= scale, r.ey *= scale;
            const vec3 xs = x * scale + t;
            const float omega = gpu::rect_solid_angle(NO_SCENE r, xs);
            const float tolerance = shift > 0.f ? 2e-3f : 1e-5f;
            EXPECT_NEAR(omega / omega1, 1.f, tolerance) << "scale " << scale << ", shift " << shift;
            for (int k = 0; k < 16; ++k) {
                const vec2 u((k % 4 + 0.3f) / 4.f, (k / 4 + 0.6f) / 4.f);
                const vec2 a = gpu::sample_rect_light(light(), x, omega1, u);
                const vec2 b = gpu::sample_rect_light(r, xs, omega, u);
                EXPECT_NEAR(b.x, a.x, 10 * tolerance) << "scale " << scale << ", shift " << shift;
                EXPECT_NEAR(b.y, a.y, 10 * tolerance) << "scale " << scale << ", shift " << shift;
            }
        }
}

// The host's pairing: a quad's two halves (either diagonal, either winding) are one
// rectangle; not a parallelogram, halves of two materials, halves facing apart, a textured
// emission, a non-emissive quad or a third triangle on the same hypotenuse.
TEST(RectLights, PairsOnlyTheHalvesOfARectangle) {
    const auto scene_with = [](std::vector<std::array<vec3, 3>> tris, bool two_materials,
                               bool emissive = true, int tex = -1) {
        Scene s;
        Material m;
        m.emission = glm::vec3(emissive ? 1.f : 0.f);
        m.color = glm::vec3(0.5f);
        m.tex_emission = tex;
        const uint32_t a = s.add_material(m);
        m.emission = glm::vec3(emissive ? 2.f : 0.f);
        const uint32_t b = s.add_material(m);
        for (size_t i = 0; i < tris.size(); ++i)
            s.triangles.push_back(
                {tris[i][0], tris[i][1], tris[i][2], two_materials && i == 1 ? b : a});
        return s;
    };
    const vec3 a(0.f, 2.f, 0.f), b(1.3f, 2.f, 0.f), d(1.3f, 2.f, 0.7f), e(0.f, 2.f, 0.7f);
    const vec3 skew(0.f, 0.f, 0.3f);  // (b + skew, d + skew: a parallelogram)
    // A right triangle on the hypotenuse a-d out of the plane (Thales: its apex on the sphere
    // of which a-d is a diameter).
    const vec3 apex = 0.5f * (a + d) + vec3(0.f, 0.5f * glm::length(d - a), 0.f);
    const struct {
        const char* what;
        Scene scene;
        size_t pairs;
    } cases[] = {
        {"a quad, diagonal a-d", scene_with({{a, b, d}, {a, d, e}}, false), 1},
        {"a quad, diagonal b-e", scene_with({{b, d, e}, {b, e, a}}, false), 1},
        {"a quad wound the other way", scene_with({{a, d, b}, {a, e, d}}, false), 1},
        {"a parallelogram", scene_with({{a, b + skew, d + skew}, {a, d + skew, e}}, false), 0},
        {"halves of two materials", scene_with({{a, b, d}, {a, d, e}}, true), 0},
        {"halves facing apart", scene_with({{a, b, d}, {a, e, d}}, false), 0},
        {"a textured emission", scene_with({{a, b, d}, {a, d, e}}, false, true, 0), 0},
        {"a quad that does not emit", scene_with({{a, b, d}, {a, d, e}}, false, false), 0},
        {"three triangles on one hypotenuse",
         scene_with({{a, b, d}, {a, d, e}, {a, apex, d}}, false), 0},
    };
    for (const auto& c : cases) {
        const std::vector<RectPair> pairs = find_rect_lights(c.scene);
        EXPECT_EQ(pairs.size(), c.pairs) << c.what;
        for (const RectPair& p : pairs) {
            EXPECT_LT(p.head, p.partner) << c.what;
            // Both halves give the device the same rectangle.
            const Triangle &h = c.scene.triangles[p.head], &q = c.scene.triangles[p.partner];
            EXPECT_NEAR(gpu::rect_area(gpu::rect_of_triangle(h.v0, h.v1, h.v2)),
                        gpu::rect_area(gpu::rect_of_triangle(q.v0, q.v1, q.v2)), 1e-6f)
                << c.what;
        }
    }
}

}  // namespace
}  // namespace mcpt
