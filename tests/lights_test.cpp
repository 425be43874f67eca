// Lights that are not surfaces, against analytic radiance on both APIs: a point light, a spot
// (its cone edge, and inner = outer), a point light with a range, and a directional light
// above a Lambertian plane, exact per pixel; point lights at 1e-3 and 1e4 distance; a convex
// Lambertian sphere under a uniform environment (rho L at any bounce limit); a plane under an
// environment with a sun 1e6 times its sky, and under a single non-zero texel. Each check has
// a negative control (a 2% brighter light must fail it). The environment's sampling routine
// against its pdf (chi-square), with a pdf missing sin(theta) as the control.
#include "common/gpu/lights.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <numeric>
#include <random>

#include "common/accel/kdtree.h"
#include "common/analysis/stats.h"
#include "common/render/gpu_scene.h"
#include "common/scene/environment.h"
#include "light_cases.h"
#include "test_util.h"

namespace mcpt {
namespace {

using test::expected_image;
using test::image_z;
using test::kPi;
using test::map_with_sun;
using test::pixels_off;
using test::plane_scene;
using test::upward_irradiance;

RenderResult render_scene(const std::string& api, const Scene& scene, int size, uint64_t spp,
                          uint32_t max_depth = 8, float light_scale = 1.f,
                          uint32_t env_strategy = 0) {
    test::CaseRender how;
    how.spp = spp, how.max_depth = max_depth, how.light_scale = light_scale;
    how.env_strategy = env_strategy;
    return test::render_case(api, scene, size, how);
}

class ExactLights : public ::testing::TestWithParam<std::string> {};

// Renders the plane lit by `light` at three scales (h = 1e-3, 1, 1e4), each exact per pixel;
// at each, a 2% brighter light is rejected by the image-wide z, and the per-pixel check
// rejects the brightest pixel 1% off (its samples scaled alone).
template <class Radiance>
void expect_plane_exact(const std::string& api, const char* what, PunctualLight light,
                        Radiance radiance_at_unit_height) {
    constexpr int kSize = 24;
    constexpr float kAlbedo = 0.5f;
    for (float h : {1e-3f, 1.f, 1e4f}) {
        Scene scene = plane_scene(kAlbedo, h, h);
        PunctualLight l = light;
        l.position *= h;
        l.range *= h;
        // Intensity grows with h^2 so that the image stays the same.
        if (l.kind != PunctualKind::Directional) l.intensity *= h * h;
        scene.punctual_lights.push_back(l);
        const std::vector<double> exact = expected_image(scene, kSize, [&](glm::dvec3 p) {
            return kAlbedo / kPi * radiance_at_unit_height(p / double(h));
        });
        const RenderResult r = render_scene(api, scene, kSize, 256);
        EXPECT_EQ(r.nonfinite_total, 0u) << what << " at h = " << h;
        const int off = pixels_off(r, exact);
        const double z = image_z(r, exact);
        // Controls: the light 2% brighter; one pixel 1% off, each in turn.
        const RenderResult bright = render_scene(api, scene, kSize, 256, 8, 1.02f);
        const double bright_z = image_z(bright, exact);
        // The brightest pixel 1% off must be caught; how many other lit pixels would be is
        // printed (where the irradiance changes fast within a pixel, 256 samples are too few).
        const size_t brightest =
            size_t(std::max_element(exact.begin(), exact.end()) - exact.begin());
        const bool caught = pixels_off(test::with_pixel_scaled(r, brightest, 1.01), exact) > off;
        int lit = 0, lit_caught = 0;
        for (size_t i = 0; i < exact.size(); ++i) {
            if (exact[i] < 0.1 * exact[brightest]) continue;
            ++lit;
            lit_caught += pixels_off(test::with_pixel_scaled(r, i, 1.01), exact) > off;
        }
        std::printf(
            "%s, %s, h = %g: %d of %d pixels off, image z %.2f; 2%% brighter: z %.1f; the "
            "brightest pixel 1%% off: %s (any lit pixel: %d of %d)\n",
            api.c_str(), what, h, off, kSize * kSize, z, bright_z, caught ? "caught" : "MISSED",
            lit_caught, lit);
        EXPECT_EQ(off, 0) << api << ": " << what << " at h = " << h;
        EXPECT_LT(std::abs(z), 4.5) << api << ": " << what << " at h = " << h;
        EXPECT_GT(bright_z, 4.5) << api << ": " << what << " at h = " << h << ": control passed";
        EXPECT_TRUE(caught) << api << ": " << what << " at h = " << h
                            << ": the brightest pixel 1% off passed the per-pixel check";
    }
}

// Irradiance at p on the plane y = 0 from a light at (0, 1, 0): I cos / r^2 (cos = 1 / r).
double point_irradiance(glm::dvec3 p, double intensity) {
    const glm::dvec3 to_l = glm::dvec3(0, 1, 0) - p;
    const double r = glm::length(to_l);
    return intensity / (r * r * r);
}

// glTF's spot falloff at cos_d of the axis.
double spot_falloff(double cos_d, double inner, double outer) {
    const double scale = 1.0 / std::max(0.001, std::cos(inner) - std::cos(outer));
    const double a = std::clamp((cos_d - std::cos(outer)) * scale, 0.0, 1.0);
    return a * a;
}

TEST_P(ExactLights, PointLightAbovePlane) {
    PunctualLight l;
    l.kind = PunctualKind::Point;
    l.position = glm::vec3(0, 1, 0);
    l.intensity = glm::vec3(2.f);
    expect_plane_exact(GetParam(), "point", l,
                       [](glm::dvec3 p) { return point_irradiance(p, 2.0); });
}

TEST_P(ExactLights, PointLightWithRange) {
    PunctualLight l;
    l.kind = PunctualKind::Point;
    l.position = glm::vec3(0, 1, 0);
    l.intensity = glm::vec3(2.f);
    l.range = 1.2f;
    expect_plane_exact(GetParam(), "point with range 1.2", l, [](glm::dvec3 p) {
        const double r = glm::length(glm::dvec3(0, 1, 0) - p);
        return point_irradiance(p, 2.0) * std::clamp(1 - std::pow(r / 1.2, 4), 0.0, 1.0);
    });
}

TEST_P(ExactLights, SpotConeEdge) {
    for (const auto& [inner, outer] : {std::pair{0.3, 0.45}, std::pair{0.35, 0.35}}) {
        PunctualLight l;
        l.kind = PunctualKind::Spot;
        l.position = glm::vec3(0, 1, 0);
        l.direction = glm::vec3(0, -1, 0);
        l.intensity = glm::vec3(3.f);
        l.inner_cone = float(inner), l.outer_cone = float(outer);
        const std::string what = "spot " + std::to_string(inner) + "/" + std::to_string(outer);
        expect_plane_exact(GetParam(), what.c_str(), l, [&](glm::dvec3 p) {
            const double r = glm::length(glm::dvec3(0, 1, 0) - p);
            return point_irradiance(p, 3.0) * spot_falloff(1.0 / r, inner, outer);
        });
    }
}

TEST_P(ExactLights, DirectionalLightTilted) {
    PunctualLight l;
    l.kind = PunctualKind::Directional;
    l.direction = glm::normalize(glm::vec3(0.5f, -1.f, 0.3f));
    l.intensity = glm::vec3(1.5f);
    const double cos_t = -double(l.direction.y);
    expect_plane_exact(GetParam(), "directional", l, [&](glm::dvec3) { return 1.5 * cos_t; });
}

TEST_P(ExactLights, PlaneUnderExtremeEnvironments) {
    const std::string api = GetParam();
    constexpr int kSize = 16;
    constexpr float kAlbedo = 0.5f;
    const struct {
        const char* what;
        Environment env;
    } cases[] = {{"uniform sky", map_with_sun(64, 32, 1.f, 0, 0, 1.f)},
                 {"sun 1e6 x sky", map_with_sun(64, 32, 1.f, 20, 8, 1e6f)},
                 {"one texel", map_with_sun(64, 32, 0.f, 40, 10, 100.f)}};
    for (const auto& c : cases) {
        Scene scene = plane_scene(kAlbedo, 1.f, 1.f);
        scene.environment = c.env;
        const double exact = kAlbedo / kPi * upward_irradiance(c.env);
        const std::vector<double> image(kSize * kSize, exact);
        const RenderResult r = render_scene(api, scene, kSize, 256);
        EXPECT_EQ(r.nonfinite_total, 0u) << c.what;
        const test::MeanEstimate e = test::pooled_mean(r);
        const int off = pixels_off(r, image);
        std::printf("%s, plane under %s: mean %.6g, exact %.6g, z %.2f, %d pixels off\n",
                    api.c_str(), c.what, e.mean, exact, e.z(exact), off);
        EXPECT_LT(std::abs(e.z(exact)), 4.5) << api << ": " << c.what;
        EXPECT_EQ(off, 0) << api << ": " << c.what;
        const RenderResult bright = render_scene(api, scene, kSize, 256, 8, 1.02f);
        EXPECT_GT(std::abs(test::pooled_mean(bright).z(exact)), 4.5)
            << api << ": " << c.what << ": a 2% brighter environment passed";
    }
}

// A sky that brightens across azimuth (0.25 to 1.75: half of it below the map's mean) with a
// sun of 30, grey.
Environment gradient_sky_and_sun() {
    Environment env = map_with_sun(64, 32, 1.f, 20, 8, 30.f);
    for (int y = 0; y < 32; ++y)
        for (int x = 0; x < 64; ++x)
            if (x != 20 || y != 8)
                for (int c = 0; c < 3; ++c)
                    env.rgb[size_t((y * 64 + x) * 3 + c)] = 0.25f + 1.5f * float(x) / 63.f;
    return env;
}

// The Lambertian plane under that sky, exact per pixel compensated (next-event estimation
// samples only what is above the mean; the half of the sky below it is BSDF sampling's alone)
// and not. Control: compensated sampling weighted by MIS with the plain pdf (texels below the
// mean, never sampled, weighted as if they were) is rejected. The exact maps before could
// not see it: a uniform map keeps the plain weights, one lit texel leaves nothing lit below
// the mean, and a sun 10^6 x the sky leaves 0.07% of the light there.
TEST_P(ExactLights, PlaneUnderGradientSkyCompensatedOrNot) {
    const std::string api = GetParam();
    constexpr int kSize = 16;
    constexpr float kAlbedo = 0.5f;
    Scene scene = plane_scene(kAlbedo, 1.f, 1.f);
    scene.environment = gradient_sky_and_sun();
    const double exact = kAlbedo / kPi * upward_irradiance(scene.environment);
    const std::vector<double> image(kSize * kSize, exact);
    for (const bool compensated : {true, false}) {
        scene.environment.compensated = compensated;
        const RenderResult r = render_scene(api, scene, kSize, 256);
        const test::MeanEstimate e = test::pooled_mean(r);
        const int off = pixels_off(r, image);
        std::printf("%s, gradient sky and sun, %s: mean %.6g, exact %.6g, z %.2f, %d pixels off\n",
                    api.c_str(), compensated ? "compensated" : "plain", e.mean, exact, e.z(exact),
                    off);
        EXPECT_EQ(r.nonfinite_total, 0u);
        EXPECT_LT(std::abs(e.z(exact)), 4.5) << api << ", compensated " << compensated;
        EXPECT_EQ(off, 0) << api << ", compensated " << compensated;
    }
    scene.environment.compensated = true;
    Scene plain = scene;
    plain.environment.compensated = false;
    test::CaseRender how;
    how.plant = [&](GpuScene& g) {
        const GpuScene p = pack_scene(plain, build_kdtree(plain.triangles, TreeOptions{}));
        for (uint32_t i = 0; i < 64 * 32; ++i) {  // the texels' pdf words (RGB, then the pdf)
            uint32_t& pdf = g.texels.at(g.params.env_word + 4 * i + 3);
            if (pdf == 0) pdf = p.texels.at(p.params.env_word + 4 * i + 3);
        }
    };
    const test::MeanEstimate planted = test::pooled_mean(test::render_case(api, scene, kSize, how));
    std::printf("%s, compensated sampling with the plain pdf in MIS: z %.1f\n", api.c_str(),
                planted.z(exact));
    EXPECT_GT(std::abs(planted.z(exact)), 4.5) << api << ": the plain pdf in MIS passed";
}

// A convex Lambertian sphere of albedo rho under a uniform environment L reflects rho L
// everywhere (it never sees itself), whatever the bounce limit >= 1.
TEST_P(ExactLights, SphereUnderUniformEnvironment) {
    const std::string api = GetParam();
    const float rho = 0.6f, radiance = 0.8f;
    Scene scene;
    Material m;
    m.color = glm::vec3(rho);
    scene.add_material(m);
    scene.spheres.push_back({glm::vec3(0.f), 1.f, 0});
    scene.camera.position = glm::vec3(0, 0, 3);
    scene.camera.yfov = 0.4f;  // the image within the sphere's outline
    scene.has_camera = true;
    scene.environment = constant_environment(glm::vec3(radiance));
    const double exact = double(rho) * double(radiance);
    for (uint32_t depth : {1u, 8u}) {
        const RenderResult r = render_scene(api, scene, 16, 128, depth);
        const test::MeanEstimate e = test::pooled_mean(r);
        std::printf("%s, sphere under uniform L, max depth %u: mean %.6g, exact %.6g, z %.2f\n",
                    api.c_str(), depth, e.mean, exact, e.z(exact));
        EXPECT_EQ(r.nonfinite_total, 0u);
        EXPECT_LT(std::abs(e.z(exact)), 4.5) << api << " depth " << depth;
        EXPECT_LT(e.std_error / exact, 0.002);
    }
    const RenderResult bright = render_scene(api, scene, 16, 128, 8, 1.02f);
    EXPECT_GT(std::abs(test::pooled_mean(bright).z(exact)), 4.5) << api << ": control passed";
}

INSTANTIATE_TEST_SUITE_P(Api, ExactLights, ::testing::ValuesIn(test::test_apis()),
                         [](const auto& info) { return info.param; });

// Mean over pixels of the squared pixel mean (channel 0): Veach's bound on what MIS may add.
double mean_squared_mean(const RenderResult& r) {
    double m2 = 0;
    for (size_t i = 0; i < r.nonfinite.size(); ++i) {
        const double mean = r.sum[3 * i] / (double(r.spp) - double(r.nonfinite[i]));
        m2 += mean * mean;
    }
    return m2 / double(r.nonfinite.size());
}

// MIS against each strategy alone (both APIs; BackendOptions::env_strategy 1: next-event
// estimation, 2: BSDF sampling): on a Lambertian plane under a small sun BSDF sampling alone
// explodes, on a near-mirror metal under a smooth sky next-event estimation alone does. MIS stays
// within Veach's bound of the better strategy (its variance + mu^2 / 2 for one sample of each:
// where one strategy is nearly exact, the other one's share costs at most that), far below
// the one that explodes, and all three agree on the mean (docs/lights.md). Controls: both
// strategies unweighted (the mean check rejects it) and both weighted 1/2 (unbiased: the
// mean check passes it, Veach's bound must reject it where one strategy explodes).
class EnvironmentMis : public ::testing::TestWithParam<std::string> {};

TEST_P(EnvironmentMis, VarianceBoundedWhereOneStrategyExplodes) {
    const std::string api = GetParam();
    const Environment sun_sky = map_with_sun(64, 32, 1.f, 20, 8, 1e4f);
    Environment sky = map_with_sun(64, 32, 1.f, 0, 0, 1.f);
    for (int y = 0; y < 32; ++y)  // brighter toward +Y
        for (int x = 0; x < 64; ++x)
            for (int c = 0; c < 3; ++c) sky.rgb[size_t((y * 64 + x) * 3 + c)] = 2.f - y / 32.f;
    Scene diffuse = plane_scene(0.5f, 1.f, 1.f);
    diffuse.environment = sun_sky;
    Scene metal = plane_scene(0.5f, 1.f, 1.f);
    metal.materials[0].type = MaterialType::Pbr;
    metal.materials[0].metallic = 1.f, metal.materials[0].roughness = 0.05f;
    metal.materials[0].color = glm::vec3(0.9f);
    metal.environment = sky;
    Scene glossy_sun = metal;
    glossy_sun.materials[0].roughness = 0.3f;
    glossy_sun.environment = sun_sky;
    const struct {
        const char* what;
        const Scene& scene;
        int explodes;  // the strategy alone whose variance explodes (1 or 2; 0: none asked)
    } cases[] = {{"Lambertian plane, sun 1e4 x sky", diffuse, 2},
                 {"metal, roughness 0.05, smooth sky", metal, 1},
                 {"metal, roughness 0.3, sun 1e4 x sky", glossy_sun, 0}};
    std::printf(
        "%s:\n| scene | variance MIS | NEE only / MIS | BSDF only / MIS | halves / MIS | "
        "mu^2/2 |\n|---|---|---|---|---|---|\n",
        api.c_str());
    for (const auto& c : cases) {
        // Strategies 0 (MIS), 1, 2, and 4 (halves) at k = 3.
        double var[4], mean[4], se[4], mu2 = 0;
        for (int k = 0; k < 4; ++k) {
            const RenderResult r =
                render_scene(api, c.scene, 16, 256, 8, 1.f, uint32_t(k == 3 ? 4 : k));
            EXPECT_EQ(r.nonfinite_total, 0u) << c.what;
            var[k] = test::mean_sample_variance(r);
            if (k == 0) mu2 = mean_squared_mean(r);
            const test::MeanEstimate e = test::pooled_mean(r);
            mean[k] = e.mean, se[k] = e.std_error;
        }
        std::printf("| %s | %.4g | %.3g | %.3g | %.3g | %.3g |\n", c.what, var[0], var[1] / var[0],
                    var[2] / var[0], var[3] / var[0], 0.5 * mu2);
        for (int k = 1; k < 4; ++k)
            EXPECT_LT(std::abs(mean[k] - mean[0]) / std::hypot(se[k], se[0]), 4.5)
                << c.what << ": strategy " << k << " disagrees on the mean";
        EXPECT_LT(var[0], std::min(var[1], var[2]) + 0.5 * mu2) << c.what;
        if (c.explodes) {
            EXPECT_GT(var[c.explodes], 10 * var[0]) << c.what;
            // Control: the halves are unbiased (above) but fail the bound.
            EXPECT_GT(var[3], std::min(var[1], var[2]) + 0.5 * mu2)
                << c.what << ": constant weights 1/2 passed Veach's bound";
        }
    }
    // Negative control: both strategies unweighted count the environment twice; the mean check
    // above must see it.
    const RenderResult mis = render_scene(api, diffuse, 16, 256);
    const RenderResult twice = render_scene(api, diffuse, 16, 256, 8, 1.f, 3);
    const test::MeanEstimate a = test::pooled_mean(mis), b = test::pooled_mean(twice);
    EXPECT_GT(std::abs(b.mean - a.mean) / std::hypot(a.std_error, b.std_error), 4.5)
        << "counting the environment twice passed";
}

INSTANTIATE_TEST_SUITE_P(Api, EnvironmentMis, ::testing::ValuesIn(test::test_apis()),
                         [](const auto& info) { return info.param; });

// The environment's sampling routine (the device code, compiled for the CPU) against its pdf:
// directions binned over the sphere in equal-area cells that do not follow the texels, the
// expected counts from the pdf integrated over each cell. Control: the pdf without sin(theta).
TEST(EnvironmentSampling, ChiSquareAgainstPdf) {
    Scene scene = plane_scene(0.5f, 1.f, 1.f);
    std::mt19937 rng(7);
    Environment env = map_with_sun(24, 12, 1.f, 5, 3, 40.f);
    for (float& v : env.rgb) v *= std::uniform_real_distribution<float>(0.2f, 1.f)(rng);
    env.rotate_deg = 30.f;
    scene.environment = env;
    const GpuScene g = pack_scene(scene, build_kdtree(scene.triangles, TreeOptions{}));
    const gpu::GpuParams* p = &g.params;
    const uint32_t* texels = g.texels.data();
#define ENV_ARGS p, nullptr, nullptr, nullptr, nullptr, nullptr, nullptr, nullptr, nullptr, texels,
    constexpr int kPhi = 40, kCos = 20, kSamples = 400000;
    const auto cell = [&](glm::vec3 d) {
        const double phi = std::atan2(double(d.z), double(d.x)) + kPi;
        const int i = std::min(kPhi - 1, int(phi / (2 * kPi) * kPhi));
        const int j = std::min(kCos - 1, int((double(d.y) + 1) / 2 * kCos));
        return size_t(j * kPhi + i);
    };
    std::vector<double> observed(kPhi * kCos, 0.0);
    std::uniform_real_distribution<float> uniform(0.f, 1.f);
    for (int k = 0; k < kSamples; ++k) {
        const gpu::LightSample s =
            gpu::sample_environment(ENV_ARGS uniform(rng), uniform(rng), 1.f);
        ASSERT_TRUE(s.valid) << "sample " << k;
        observed[cell(s.wi)] += 1;
    }
    // Expected, exactly: the device's pdf is constant per texel in (u, v) (its w), so a cell's
    // probability is the sum over texels of w times the (u, v) area they share. A cell is an
    // interval of phi (a u interval, shifted by the rotation, wrapping) and of cos theta (a v
    // interval). The control's pdf lacks 1 / sin(theta): w sin(pi v) integrated instead.
    const uint32_t W = p->env_width, H = p->env_height;
    const double shift = double(p->env_u_shift);
    const auto u_overlap = [&](double lo, double hi, uint32_t x) {  // [lo, hi) mod 1
        const double len = hi - lo;
        lo -= std::floor(lo), hi = lo + len;
        const double a = double(x) / W, b = double(x + 1) / W;
        double total = std::max(0.0, std::min(std::min(hi, 1.0), b) - std::max(lo, a));
        if (hi > 1) total += std::max(0.0, std::min(hi - 1, b) - a);
        return total;
    };
    const auto expected_counts = [&](bool control) {
        std::vector<double> expected(kPhi * kCos, 0.0);
        for (int j = 0; j < kCos; ++j) {
            // v = acos(cos theta) / pi, decreasing in cos theta.
            const double v_lo = std::acos(std::min(1.0, -1 + 2.0 * (j + 1) / kCos)) / kPi;
            const double v_hi = std::acos(std::max(-1.0, -1 + 2.0 * j / kCos)) / kPi;
            for (int i = 0; i < kPhi; ++i) {
                double prob = 0;
                for (uint32_t y = 0; y < H; ++y) {
                    const double a = std::max(v_lo, double(y) / H),
                                 b = std::min(v_hi, double(y + 1) / H);
                    if (b <= a) continue;
                    const double v_part =
                        control ? (std::cos(kPi * a) - std::cos(kPi * b)) / kPi : b - a;
                    for (uint32_t x = 0; x < W; ++x) {
                        const double u_part =
                            u_overlap(double(i) / kPhi - shift, double(i + 1) / kPhi - shift, x);
                        if (u_part > 0)
                            prob += double(gpu::env_texel(ENV_ARGS x, y).w) * u_part * v_part;
                    }
                }
                expected[size_t(j * kPhi + i)] = prob * kSamples;
            }
        }
        return expected;
    };
#undef ENV_ARGS
    const double p_value = stats::chi_square_test(observed, expected_counts(false));
    const double p_control = stats::chi_square_test(observed, expected_counts(true));
    std::printf("chi-square, environment sampling: p = %.3f; control (no sin theta): p = %.3g\n",
                p_value, p_control);
    EXPECT_GT(p_value, 1e-3);
    EXPECT_LT(p_control, 1e-6);
}

// Compensation (Karlik et al. 2019) as packed: a texel whose luminance is below the map's
// mean (solid-angle weighted) has next-event probability 0 and every other texel its excess
// over the mean times sin(theta), up to the CDF's float steps; the plain table gives every
// lit texel its luminance. (Switching compensation off fails the first check.)
TEST(EnvironmentSampling, CompensationLeavesTexelsBelowTheMeanToBsdfSampling) {
    Scene scene = plane_scene(0.5f, 1.f, 1.f);
    scene.environment = gradient_sky_and_sun();
    const Environment& env = scene.environment;
    double lum = 0, sr = 0;
    for (int y = 0; y < 32; ++y) {
        const double s = std::sin(kPi * (y + 0.5) / 32);
        for (int x = 0; x < 64; ++x) {
            const float* c = &env.rgb[size_t((y * 64 + x) * 3)];
            lum += env_luminance(c[0], c[1], c[2]) * s, sr += s;
        }
    }
    const double mean = lum / sr;
    for (const bool compensated : {true, false}) {
        scene.environment.compensated = compensated;
        const GpuScene g = pack_scene(scene, build_kdtree(scene.triangles, TreeOptions{}));
        int zero = 0, below = 0;
        for (int y = 0; y < 32; ++y)
            for (int x = 0; x < 64; ++x) {
                const float* c = &env.rgb[size_t((y * 64 + x) * 3)];
                const double l = env_luminance(c[0], c[1], c[2]);
                float pdf;
                std::memcpy(&pdf, &g.texels.at(g.params.env_word + 4 * uint32_t(y * 64 + x) + 3),
                            4);
                below += l < mean, zero += pdf == 0.f;
                if (compensated && l < mean) {
                    ASSERT_EQ(pdf, 0.f) << "texel " << x << ", " << y << " below the mean";
                } else if (!compensated || l > mean * 1.01) {
                    ASSERT_GT(pdf, 0.f) << "texel " << x << ", " << y;
                }
            }
        std::printf("%s: %d of %d texels below the mean, %d with pdf 0\n",
                    compensated ? "compensated" : "plain", below, 64 * 32, zero);
        if (compensated) {
            EXPECT_GT(below, 64 * 32 / 3);
        }
    }
}

// Lamps by contribution pick from a stream of weights with one uniform (stream_pick): each
// weight is picked in proportion to it (chi-square over 200,000 picks). Control: the same
// stream without rescaling u between steps, which skews the picks, must be rejected.
TEST(LampChoice, StreamPickFollowsTheWeights) {
    const std::vector<float> w = {0.5f, 3.f, 1.25f, 0.05f, 2.f, 7.f, 0.2f, 1.f};
    const double total = std::accumulate(w.begin(), w.end(), 0.0);
    constexpr int kPicks = 200000;
    std::mt19937 rng(11);
    std::uniform_real_distribution<float> uniform(0.f, 1.f);
    std::vector<double> picked(w.size(), 0.0), skewed(w.size(), 0.0), expected(w.size());
    for (size_t i = 0; i < w.size(); ++i) expected[i] = kPicks * w[i] / total;
    for (int n = 0; n < kPicks; ++n) {
        const float u0 = std::min(uniform(rng), 0.99999994f);
        float u = u0, sum = 0.f;
        size_t pick = 0, skew = 0;
        for (size_t i = 0; i < w.size(); ++i) {
            sum += w[i];
            const gpu::StreamPick p = gpu::stream_pick(u, w[i], sum);
            if (p.take) pick = i;
            u = p.u;
            ASSERT_TRUE(u >= 0.f && u < 1.f) << u;
            if (u0 < w[i] / sum) skew = i;  // control: u never rescaled
        }
        picked[pick] += 1, skewed[skew] += 1;
    }
    const double p_value = stats::chi_square_test(picked, expected);
    const double p_control = stats::chi_square_test(skewed, expected);
    std::printf("chi-square, lamps by contribution: p = %.3f; control (u not rescaled): p = %.3g\n",
                p_value, p_control);
    EXPECT_GT(p_value, 1e-3);
    EXPECT_LT(p_control, 1e-6);
}

}  // namespace
}  // namespace mcpt
