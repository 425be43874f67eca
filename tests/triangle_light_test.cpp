// Emissive triangles sampled by solid angle (common/gpu/triangle_light.h, the device code
// compiled for the CPU): the solid angle against quadrature of cos / d^2 over the triangle
// (the pdf integrates to 1), a chi-square of the sampled points against the solid-angle pdf
// from receivers near, far, grazing and behind the light (control: area sampling's points
// against the same pdf), the bounds where area sampling takes over (a receiver a hair from
// the light's plane, a tiny light far away, a huge one close by), and the same samples at
// scene scales from 1e-3 to 1e4.
#include "common/gpu/triangle_light.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "solid_angle_chi_square.h"

namespace mcpt {
namespace {

using glm::dvec3;
using glm::vec2;
using glm::vec3;

struct Receiver {
    std::string name;
    vec3 x;
};

// The unit light triangle in the plane y = 1 (normal down), and receivers about it.
const vec3 kV0(0.f, 1.f, 0.f), kV1(1.f, 1.f, 0.f), kV2(0.f, 1.f, 1.f);
std::vector<Receiver> receivers() {
    return {{"near, under the middle", vec3(0.3f, 0.95f, 0.3f)},
            {"near, beside an edge", vec3(0.6f, 0.9f, 0.7f)},
            {"under a vertex", vec3(0.f, 0.7f, 0.f)},
            {"far", vec3(2.f, -4.f, 1.f)},
            {"grazing, 0.02 below the plane", vec3(-0.8f, 0.98f, 0.4f)},
            {"behind", vec3(0.2f, 1.3f, 0.3f)}};
}

// A point of the triangle from canonical (u1, u2), uniform in area, and back.
dvec3 point_at(double u1, double u2) {
    const double su = std::sqrt(u1), b1 = u2 * su, b2 = 1 - su;
    return dvec3(kV0) * (1 - b1 - b2) + dvec3(kV1) * b1 + dvec3(kV2) * b2;
}

// The solid angle of the part of the triangle whose canonical coordinates lie in
// [u1a, u1b) x [u2a, u2b): cos_l / d^2 over its area, by the midpoint rule on n x n points.
double solid_angle_of(dvec3 x, double u1a, double u1b, double u2a, double u2b, int n) {
    const dvec3 normal(0, -1, 0);
    const double area = 0.5 * (u1b - u1a) * (u2b - u2a);  // the map is area-preserving
    double sum = 0;
    for (int i = 0; i < n; ++i)
        for (int j = 0; j < n; ++j) {
            const dvec3 p =
                point_at(u1a + (u1b - u1a) * (i + 0.5) / n, u2a + (u2b - u2a) * (j + 0.5) / n);
            const dvec3 d = p - x;
            const double d2 = glm::dot(d, d);
            sum += std::abs(glm::dot(normal, d)) / (d2 * std::sqrt(d2));
        }
    return sum * area / (double(n) * n);
}

TEST(TriangleLight, SolidAngleIsTheIntegralOfCosOverDistanceSquared) {
    for (const Receiver& r : receivers()) {
        const float omega = gpu::triangle_solid_angle_at(kV0, kV1, kV2, r.x);
        const double quadrature = solid_angle_of(dvec3(r.x), 0, 1, 0, 1, 2000);
        std::printf("%-30s solid angle %.6f sr, quadrature %.6f\n", r.name.c_str(), omega,
                    quadrature);
        ASSERT_GT(omega, 0.f) << r.name << ": sampled by area";
        EXPECT_NEAR(omega / quadrature, 1.0, 2e-4) << r.name;
    }
}

// Canonical coordinates of a point of the triangle (the inverse of point_at).
vec2 canonical(vec2 b) {
    const float su = 1.f - b.y;
    return vec2(su * su, su > 0.f ? b.x / su : 0.f);
}

TEST(TriangleLight, SampledDirectionsFollowTheSolidAnglePdf) {
    constexpr int kCells = 12, kSamples = 200000;
    for (const Receiver& r : receivers()) {
        const float omega = gpu::triangle_solid_angle_at(kV0, kV1, kV2, r.x);
        ASSERT_GT(omega, 0.f) << r.name;
        // Per canonical cell: its solid angle over the whole.
        const auto [p, p_area] = test::solid_angle_chi_square(
            kCells, kSamples, omega, 11,
            [&](int i, int j) {
                return solid_angle_of(dvec3(r.x), double(i) / kCells, double(i + 1) / kCells,
                                      double(j) / kCells, double(j + 1) / kCells, 24);
            },
            [&](vec2 u, bool by_area) {
                const vec2 b =
                    gpu::sample_triangle_light(kV0, kV1, kV2, r.x, by_area ? 0.f : omega, u);
                EXPECT_TRUE(std::isfinite(b.x) && std::isfinite(b.y) && b.x >= 0.f && b.y >= 0.f &&
                            b.x + b.y <= 1.f + 1e-6f);
                return canonical(b);
            });
        std::printf("%-30s chi-square p = %.3f; control (by area): p = %.3g\n", r.name.c_str(), p,
                    p_area);
        EXPECT_GT(p, 1e-3) << r.name;
        EXPECT_LT(p_area, 1e-6) << r.name << ": area sampling passed the solid-angle pdf";
    }
}

// Where the solid angle is too small for float arithmetic or nearly a hemisphere, or the
// light is far for its size, the triangle is sampled by area: 0 from triangle_solid_angle,
// and finite samples inside the triangle either way.
TEST(TriangleLight, AreaSamplingTakesOverAtTheExtremes) {
    const struct {
        const char* what;
        vec3 v0, v1, v2, x;
        bool by_area;
    } cases[] = {
        {"a receiver 1e-6 from the light's plane", kV0, kV1, kV2, vec3(1.5f, 1.f - 1e-6f, 0.5f),
         true},
        {"a receiver in the light's plane", kV0, kV1, kV2, vec3(1.5f, 1.f, 0.5f), true},
        {"a light of 1e-3 at 10", kV0 * 1e-3f, kV1 * 1e-3f, kV2 * 1e-3f, vec3(0.f, -10.f, 0.f),
         true},
        {"a light of 1e4 at 1e-2", kV0 * 1e4f, kV1 * 1e4f, kV2 * 1e4f,
         vec3(20.f, 1e4f - 1e-2f, 20.f), true},
        {"a receiver on a vertex", kV0, kV1, kV2, kV0, true},
        {"a light far for its size (area / d^2 0.018)", kV0, kV1, kV2, vec3(2.f, -4.f, 1.f), true},
        {"a light of 1 at 1", kV0, kV1, kV2, vec3(0.3f, 0.f, 0.3f), false},
    };
    for (const auto& c : cases) {
        const float omega = gpu::triangle_solid_angle(NO_SCENE c.v0, c.v1, c.v2, c.x);
        EXPECT_EQ(omega == 0.f, c.by_area) << c.what << ": solid angle " << omega;
        for (const vec2 u : {vec2(0.f, 0.f), vec2(0.5f, 0.5f), vec2(0.99999994f, 0.99999994f),
                             vec2(0.f, 0.99999994f), vec2(0.99999994f, 0.f)}) {
            const vec2 b = gpu::sample_triangle_light(c.v0, c.v1, c.v2, c.x, omega, u);
            EXPECT_TRUE(std::isfinite(b.x) && std::isfinite(b.y) && b.x >= 0.f && b.y >= 0.f &&
                        b.x + b.y <= 1.f + 1e-6f)
                << c.what << ": " << b.x << ", " << b.y;
        }
    }
    // The scene's flag turns solid-angle sampling off.
    gpu::GpuParams by_area{};
    by_area.scene_flags = SCENE_TRIANGLE_LIGHTS_BY_AREA;
    EXPECT_EQ(
        gpu::triangle_solid_angle(&by_area, nullptr, nullptr, nullptr, nullptr, nullptr, nullptr,
                                  nullptr, nullptr, nullptr, kV0, kV1, kV2, vec3(0.3f, 0.f, 0.3f)),
        0.f);
}

// The same light and receiver at scales 1e-3 to 1e4, and moved 1e3 away from the origin: the
// same solid angle and the same points (in the light's own barycentrics) for the same
// uniforms, to float precision.
TEST(TriangleLight, SameSamplesAtEveryScale) {
    const vec3 x(0.2f, 0.6f, 0.3f);
    const float omega1 = gpu::triangle_solid_angle(NO_SCENE kV0, kV1, kV2, x);
    ASSERT_GT(omega1, 0.f);
    for (const float scale : {1e-3f, 1e-1f, 1e2f, 1e4f})
        for (const float shift : {0.f, 1e3f}) {
            const vec3 t(shift, -shift, 0.5f * shift);
            const vec3 v0 = kV0 * scale + t * scale, v1 = kV1 * scale + t * scale,
                       v2 = kV2 * scale + t * scale, xs = x * scale + t * scale;
            const float omega = gpu::triangle_solid_angle(NO_SCENE v0, v1, v2, xs);
            // Far from the origin the differences v - x lose bits in proportion to the shift.
            const float tolerance = shift > 0.f ? 2e-3f : 1e-5f;
            EXPECT_NEAR(omega / omega1, 1.f, tolerance) << "scale " << scale << ", shift " << shift;
            for (int k = 0; k < 16; ++k) {
                const vec2 u((k % 4 + 0.3f) / 4.f, (k / 4 + 0.6f) / 4.f);
                const vec2 b1 = gpu::sample_triangle_light(kV0, kV1, kV2, x, omega1, u);
                const vec2 b = gpu::sample_triangle_light(v0, v1, v2, xs, omega, u);
                EXPECT_NEAR(b.x, b1.x, 10 * tolerance) << "scale " << scale << ", shift " << shift;
                EXPECT_NEAR(b.y, b1.y, 10 * tolerance) << "scale " << scale << ", shift " << shift;
            }
        }
}

}  // namespace
}  // namespace mcpt
