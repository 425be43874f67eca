// Emissive triangles sampled by solid angle, rendered on both APIs: a Lambertian plane under
// an emissive triangle and a quad is exact per pixel (Lambert's polygon formula) at the lamp
// tests' three scales, the quad 0.02 above the plane's height just beside it (where area
// sampling's distance^2 / cos explodes), and lights 2% brighter are rejected; a glossy plane
// agrees with area sampling, and a pdf 1.5x in the MIS weight of BSDF-sampled hits alone
// (next-event estimation unchanged) is rejected. And the variance per sample against
// area sampling (--triangle-light-sampling area), on the Cornell box and on the plane beside
// its large, close light: never more than noise above it; nor a rectangle sampled whole
// (rect_light.h) above its two halves sampled one by one (--triangle-light-sampling triangles).
// The warp toward the receiver's cosine: exact beside a standing light (a forgotten density
// rejected), and lowering direct light's variance (a warp toward the wrong corners rejected).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>

#include "common/scene/builtin_scenes.h"
#include "light_cases.h"
#include "test_util.h"

namespace mcpt {
namespace {

using test::kPi;

constexpr int kSize = 24;
constexpr float kAlbedo = 0.5f;

// The plane of half-size h at y = 0, a quad of radiance 2 at y = 0.02 h beside it (x from
// 1.05 h to 2 h) and a triangle of radiance 3 at y = 2 h outside the view (the camera, at 3 h,
// sees its reflection on a shiny plane), both facing down.
struct PlaneUnderLights {
    Scene scene;
    std::vector<glm::dvec3> quad, triangle;
};
PlaneUnderLights plane_under_lights(float h) {
    PlaneUnderLights s{test::plane_scene(kAlbedo, h, h), {}, {}};
    Material m;
    m.color = glm::vec3(0.f);
    m.emission = glm::vec3(2.f);
    const uint32_t quad_mat = uint32_t(s.scene.add_material(m));
    m.emission = glm::vec3(3.f);
    const uint32_t tri_mat = uint32_t(s.scene.add_material(m));
    const glm::vec3 a(1.05f * h, 0.02f * h, -0.6f * h), b(2.f * h, 0.02f * h, -0.6f * h),
        c(2.f * h, 0.02f * h, 0.6f * h), d(1.05f * h, 0.02f * h, 0.6f * h);
    s.scene.triangles.push_back({a, b, c, quad_mat});
    s.scene.triangles.push_back({a, c, d, quad_mat});
    const glm::vec3 e(-1.6f * h, 2.f * h, -0.5f * h), f(-1.f * h, 2.f * h, -0.5f * h),
        g(-1.6f * h, 2.f * h, 0.5f * h);
    s.scene.triangles.push_back({e, f, g, tri_mat});
    s.quad = {a, b, c, d};
    s.triangle = {e, f, g};
    return s;
}

class TriangleLightRender : public ::testing::TestWithParam<std::string> {};

TEST_P(TriangleLightRender, PlaneUnderATriangleAndAQuadIsExactAtEveryScale) {
    const std::string api = GetParam();
    for (const float h : {1e-3f, 1.f, 1e4f}) {
        const PlaneUnderLights s = plane_under_lights(h);
        const std::vector<double> exact = test::expected_image(s.scene, kSize, [&](glm::dvec3 p) {
            return kAlbedo / kPi *
                   (test::polygon_irradiance(p, s.quad, 2.0) +
                    test::polygon_irradiance(p, s.triangle, 3.0));
        });
        test::CaseRender how;
        how.spp = 512;
        const RenderResult r = test::render_case(api, s.scene, kSize, how);
        how.light_scale = 1.02f;  // control: the lights 2% brighter
        const RenderResult brighter = test::render_case(api, s.scene, kSize, how);
        const int off = test::pixels_off(r, exact);
        const double z = test::image_z(r, exact), brighter_z = test::image_z(brighter, exact);
        std::printf("%s, h = %g: %d of %d pixels off, image z %.2f; 2%% brighter: z %.1f\n",
                    api.c_str(), h, off, kSize * kSize, z, brighter_z);
        EXPECT_EQ(r.nonfinite_total, 0u) << h;
        EXPECT_EQ(off, 0) << api << ", h = " << h;
        EXPECT_LT(std::abs(z), 4.5) << api << ", h = " << h;
        EXPECT_GT(std::abs(brighter_z), 4.5) << api << ", h = " << h << ": 2% brighter passed";
    }
}

// The plane of half-size h and a rectangle light of radiance 2 standing at its edge, facing it
// (x = 1.05 h, y from 0.02 h to h, z from -h to h): each receiver sees the light's corners at
// cosines from 0.01 to 0.6, where the warp toward the receiver's cosine changes the samples most;
// or its upper half alone (a lone triangle).
PlaneUnderLights plane_beside_a_wall_light(float h, bool whole) {
    PlaneUnderLights s{test::plane_scene(kAlbedo, h, h), {}, {}};
    Material m;
    m.color = glm::vec3(0.f);
    m.emission = glm::vec3(2.f);
    const uint32_t mat = uint32_t(s.scene.add_material(m));
    const glm::vec3 a(1.05f * h, 0.02f * h, -h), b(1.05f * h, h, -h), c(1.05f * h, h, h),
        d(1.05f * h, 0.02f * h, h);
    s.scene.triangles.push_back({a, c, b, mat});  // facing -x
    s.quad = {a, b, c};
    if (whole) {
        s.scene.triangles.push_back({a, d, c, mat});
        s.quad = {a, b, c, d};
    }
    return s;
}

// The warp toward the receiver's cosine (--triangle-light-sampling cosine) against Lambert's
// polygon formula beside the standing light at every scale, and its half alone; and warped
// where the light spans 0.2 sr or more (the default: most receivers here). Control (OpenCL:
// defines reach its kernel only; the device source is one): the warp's density forgotten (the
// samples move toward the corners the receiver faces, their value does not drop to match).
TEST_P(TriangleLightRender, CosineWarpIsExactBesideAStandingLight) {
    const std::string api = GetParam();
    using Tls = Scene::TriangleLightSampling;
    const struct {
        float h;
        bool whole;
        Tls how_sampled;
    } cases[] = {{1e-3f, true, Tls::Cosine},
                 {1.f, true, Tls::Cosine},
                 {1e4f, true, Tls::Cosine},
                 {1.f, false, Tls::Cosine},
                 {1.f, true, Tls::SolidAngle}};
    for (const auto [h, whole, how_sampled] : cases) {
        PlaneUnderLights s = plane_beside_a_wall_light(h, whole);
        s.scene.triangle_light_sampling = how_sampled;
        const std::vector<double> exact = test::expected_image(s.scene, kSize, [&](glm::dvec3 p) {
            return kAlbedo / kPi * test::polygon_irradiance(p, s.quad, 2.0);
        });
        test::CaseRender how;
        how.spp = 512;
        const RenderResult r = test::render_case(api, s.scene, kSize, how);
        const int off = test::pixels_off(r, exact);
        const double z = test::image_z(r, exact);
        const char* warped = how_sampled == Tls::Cosine ? "everywhere" : "from 0.2 sr";
        std::printf("%s, %s warped %s, h = %g: %d of %d pixels off, image z %.2f\n", api.c_str(),
                    whole ? "rectangle" : "triangle", warped, h, off, kSize * kSize, z);
        EXPECT_EQ(r.nonfinite_total, 0u) << h;
        EXPECT_EQ(off, 0) << api << ", h = " << h;
        EXPECT_LT(std::abs(z), 4.5) << api << ", h = " << h;
        if (api != "opencl") continue;
        how.defines = "-DMCPT_NEGATIVE_CONTROL_WARP_DENSITY";
        const RenderResult planted = test::render_case(api, s.scene, kSize, how);
        const double planted_z = test::image_z(planted, exact);
        std::printf("  density forgotten: z %.1f, %d pixels off\n", planted_z,
                    test::pixels_off(planted, exact));
        EXPECT_GT(std::abs(planted_z), 4.5) << "h = " << h << ": the planted warp passed";
    }
}

// The pdfs meet in the MIS weights where a glossy receiver's BSDF lobe and the light compete:
// a metal plane of roughness 0.3 under the same lights, by solid angle against by area (an
// independent estimator, at about equal error bars: 4x its samples), per pixel and
// image-wide. Control: the light's pdf in the MIS weight of BSDF-sampled hits 1.5x (the
// power total its pick is recomputed from, 1.5x low), next-event estimation unchanged (it
// takes the alias table's): the weights no longer sum to one, z -7.2. With the pdf k times
// off, the sum drops by 1/2 - 1/(1 + k^2) where the two pdfs are equal and less elsewhere:
// 1% at k = 1.02, which these images show at z -0.3 (k = 1.2: -2.9), below what they resolve.
TEST_P(TriangleLightRender, GlossyPlaneAgreesWithAreaSampling) {
    const std::string api = GetParam();
    PlaneUnderLights s = plane_under_lights(1.f);
    Material& plane = s.scene.materials[0];
    plane.type = MaterialType::Pbr;
    plane.metallic = 1.f, plane.roughness = 0.3f;
    plane.color = glm::vec3(0.8f);
    Scene by_area = s.scene;
    by_area.triangle_light_sampling = Scene::TriangleLightSampling::Area;
    test::CaseRender how;
    how.spp = 1024;
    const RenderResult area = test::render_case(api, by_area, kSize, how);
    how.spp = 256;
    const RenderResult solid = test::render_case(api, s.scene, kSize, how);
    how.plant = [](GpuScene& g) { g.params.light_power_total /= 1.5f; };
    const RenderResult planted = test::render_case(api, s.scene, kSize, how);
    const test::MeanEstimate a = test::pooled_mean(area), b = test::pooled_mean(solid),
                             c = test::pooled_mean(planted);
    const double z = (b.mean - a.mean) / std::hypot(a.std_error, b.std_error);
    const double planted_z = (c.mean - a.mean) / std::hypot(a.std_error, c.std_error);
    const int apart = test::pixels_apart(solid, area);
    std::printf(
        "%s, glossy plane: solid angle %.5f +- %.5f, area %.5f +- %.5f, z %.2f, %d pixels "
        "apart; MIS pdf 1.5x: z %.1f, %d pixels apart\n",
        api.c_str(), b.mean, b.std_error, a.mean, a.std_error, z, apart, planted_z,
        test::pixels_apart(planted, area));
    EXPECT_EQ(solid.nonfinite_total + area.nonfinite_total, 0u);
    EXPECT_LT(std::abs(z), 4.5) << api;
    EXPECT_EQ(apart, 0) << api;
    EXPECT_GT(std::abs(planted_z), 4.5) << api << ": the MIS pdf 1.5x passed";
}

INSTANTIATE_TEST_SUITE_P(Api, TriangleLightRender, ::testing::ValuesIn(test::test_apis()),
                         [](const auto& info) { return info.param; });

// The Cornell box with its light emitting from both faces, as Cycles renders it: the ceiling
// 0.02 above the light sees its back at grazing angles.
Scene cornell_two_sided() {
    Scene s = make_builtin_scene("cornell");
    for (Material& m : s.materials)
        if (m.is_emissive()) m.two_sided = true;
    return s;
}

// `scene` with its emissive triangles sampled as `how_sampled`, on PoCL, size x size, 128
// spp, to max_depth (defines: a control's), for the variance tests below (same seeds).
RenderResult render_sampled(Scene scene, Scene::TriangleLightSampling how_sampled, int size,
                            int max_depth, const char* defines = "") {
    scene.triangle_light_sampling = how_sampled;
    test::CaseRender how;
    how.spp = 128;
    how.max_depth = max_depth;
    how.defines = defines;
    return test::render_case("opencl", scene, size, how);
}

// Solid angle against area, same seeds, on PoCL: the per-sample variance of each (the means
// agree: both are exact where the plane test says so). Never above area sampling's by more
// than its noise (8% on these images), and below it where receivers see the light at grazing
// angles close by (measured at 128 x 128, max depth 8: 0.84 on the two-sided box; 0.94 here).
// And a rectangle's halves as one spherical rectangle against each half on its own
// (--triangle-light-sampling triangles): never above it either.
TEST(TriangleLightVariance, NeverAboveAreaSampling) {
    using Tls = Scene::TriangleLightSampling;
    const struct {
        const char* what;
        Scene scene;
        double at_most;       // solid angle / area
        double rect_at_most;  // rectangles / triangles
    } cases[] = {{"Cornell box", make_builtin_scene("cornell"), 1.08, 1.08},
                 {"plane beside a close quad", plane_under_lights(1.f).scene, 1.08, 1.08},
                 {"Cornell box, light two-sided", cornell_two_sided(), 1.02, 1.02}};
    for (const auto& c : cases) {
        double variance[5] = {};
        for (const Tls how_sampled : {Tls::SolidAngle, Tls::Triangles, Tls::Area})
            variance[int(how_sampled)] =
                test::mean_sample_variance(render_sampled(c.scene, how_sampled, 32, 3));
        const double by_area = variance[0] / variance[int(Tls::Area)],
                     by_triangles = variance[0] / variance[int(Tls::Triangles)];
        std::printf(
            "%s: variance per sample, solid angle / area: %.3f; rectangles / triangles: %.3f\n",
            c.what, by_area, by_triangles);
        EXPECT_LT(by_area, c.at_most) << c.what;
        EXPECT_LT(by_triangles, c.rect_at_most) << c.what;
    }
}

// The warp toward the receiver's cosine against uniform samples over the solid angle
// (--triangle-light-sampling uniform), same seeds, on PoCL, direct light only (max depth 1: the
// warp changes next-event estimation alone, and behind one bounce its gain drowns in the
// bounce's own noise: 0.997 on the two-sided box at depth 8). Warped everywhere (cosine): below
// uniform where receivers see the light close by at varied angles (the boxes: 0.87 and 0.89
// at 64 x 64; the two-sided Blender box at 128 x 128: 0.80; the plane beside the standing
// light: 0.13), never above it by more than noise. The default, warped where the light spans
// 0.2 sr or more: the standing light's gain kept (0.13), the boxes' given up (their receivers
// that gain see the light small and at grazing angles), never above uniform by more than
// noise. Control: the warp toward the wrong corners (mirrored), unbiased but above uniform.
TEST(TriangleLightVariance, CosineWarpLowersDirectLightsVariance) {
    using Tls = Scene::TriangleLightSampling;
    const struct {
        const char* what;
        Scene scene;
        double at_most;          // warped everywhere / uniform
        double default_at_most;  // the default / uniform
    } cases[] = {
        {"Cornell box", make_builtin_scene("cornell"), 0.95, 1.03},
        {"plane beside a close quad", plane_under_lights(1.f).scene, 1.02, 1.03},
        {"Cornell box, light two-sided", cornell_two_sided(), 0.95, 1.03},
        {"plane beside a standing light", plane_beside_a_wall_light(1.f, true).scene, 0.3, 0.3}};
    for (const auto& c : cases) {
        const auto variance = [&](Tls how_sampled, const char* defines) {
            return test::mean_sample_deviation_squared(
                render_sampled(c.scene, how_sampled, 64, 1, defines));
        };
        const double uniform = variance(Tls::Uniform, ""), warped = variance(Tls::Cosine, ""),
                     by_default = variance(Tls::SolidAngle, "");
        const bool control = c.at_most < 1.0;
        const double mirrored =
            control ? variance(Tls::Cosine, "-DMCPT_NEGATIVE_CONTROL_WARP") : uniform;
        std::printf(
            "%s: direct light's variance per sample against uniform: warped everywhere %.3f, "
            "the default %.3f; control (mirrored): %.3f\n",
            c.what, warped / uniform, by_default / uniform, mirrored / uniform);
        EXPECT_LT(warped, c.at_most * uniform) << c.what;
        EXPECT_LT(by_default, c.default_at_most * uniform) << c.what;
        if (control) {
            EXPECT_GT(mirrored, uniform) << c.what << ": the mirrored warp passed";
        }
    }
}

}  // namespace
}  // namespace mcpt
