// Several lights at once against exact radiance, on both APIs: their radiance adds, so a
// Lambertian plane under a point lamp and an emissive quad, under a uniform map and a lamp,
// and under a map with a sun and a directional light is exact per pixel. The light choice
// (the alias table's pick probabilities) is what these scenes test that single-light scenes
// cannot: a probability both APIs share, off by 10% for one light (the pick itself
// unchanged), must be rejected.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "common/analysis/stats.h"
#include "light_cases.h"
#include "test_util.h"

namespace mcpt {
namespace {

using test::kPi;

constexpr int kSize = 24;
constexpr float kAlbedo = 0.5f;

// Irradiance from a point light of intensity I at (0, 1, 0).
double lamp_irradiance(glm::dvec3 p, double intensity) {
    const double r = glm::length(glm::dvec3(0, 1, 0) - p);
    return intensity / (r * r * r);
}

PunctualLight lamp(float intensity) {
    PunctualLight l;
    l.kind = PunctualKind::Point;
    l.position = glm::vec3(0, 1, 0);
    l.intensity = glm::vec3(intensity);
    return l;
}

class SeveralLights : public ::testing::TestWithParam<std::string> {};

// Lights at infinity beside the local ones (the tree's planted defect needs them).
bool g_has_local(const Scene& s) {
    for (const PunctualLight& l : s.punctual_lights)
        if (l.kind != PunctualKind::Directional) return true;
    for (const Triangle& t : s.triangles)
        if (s.materials[t.material].is_emissive()) return true;
    return false;
}

bool g_has_far(const Scene& s) {
    if (s.environment.present()) return true;
    for (const PunctualLight& l : s.punctual_lights)
        if (l.kind == PunctualKind::Directional) return true;
    return false;
}

// The scene exact per pixel and image-wide; with `plant` (one light's pick probability off
// by 10%) rejected image-wide.
void expect_exact_with_control(const std::string& api, const char* what_in, const Scene& scene_in,
                               const std::function<double(glm::dvec3)>& irradiance,
                               const std::function<void(GpuScene&)>& plant_in) {
    for (bool tree : {false, true}) {
        Scene scene = scene_in;
        scene.light_tree = tree;
        const std::string label = std::string(what_in) + (tree ? ", light tree" : "");
        const char* what = label.c_str();
        // With the tree: the probability of taking it 50% off (lights at infinity keep theirs:
        // picked less often than their pmf says) where there are lights at infinity and a tree.
        const std::function<void(GpuScene&)> plant =
            !tree ? plant_in : [](GpuScene& g) { g.params.light_tree_pmf *= 1.5f; };
        const std::vector<double> exact = test::expected_image(
            scene, kSize, [&](glm::dvec3 p) { return kAlbedo / kPi * irradiance(p); });
        test::CaseRender how;
        const RenderResult r = test::render_case(api, scene, kSize, how);
        how.plant = plant;
        const RenderResult planted = test::render_case(api, scene, kSize, how);
        const int off = test::pixels_off(r, exact);
        const double z = test::image_z(r, exact), planted_z = test::image_z(planted, exact);
        std::printf(
            "%s, %s: %d of %d pixels off, image z %.2f; a planted pick probability: z %.1f\n",
            api.c_str(), what, off, kSize * kSize, z, planted_z);
        EXPECT_EQ(r.nonfinite_total, 0u) << what;
        EXPECT_EQ(off, 0) << api << ": " << what;
        EXPECT_LT(std::abs(z), 4.5) << api << ": " << what;
        if (tree && !(g_has_far(scene) && g_has_local(scene))) continue;
        EXPECT_GT(std::abs(planted_z), 4.5) << api << ": " << what << ": the planted pick passed";
    }
}

TEST_P(SeveralLights, LampAndEmissiveQuad) {
    Scene scene = test::plane_scene(kAlbedo, 1.f, 1.f);
    scene.punctual_lights.push_back(lamp(2.f));
    // A quad of radiance 3 facing down at y = 1.2, beside the view (and above the lamp).
    Material m;
    m.color = glm::vec3(0.f);
    m.emission = glm::vec3(3.f);
    const uint32_t mat = uint32_t(scene.add_material(m));
    const glm::vec3 a(1.2f, 1.2f, -0.5f), b(2.2f, 1.2f, -0.5f), c(2.2f, 1.2f, 0.5f),
        d(1.2f, 1.2f, 0.5f);
    scene.triangles.push_back({a, b, c, mat});
    scene.triangles.push_back({a, c, d, mat});
    const std::vector<glm::dvec3> quad = {a, b, c, d};
    expect_exact_with_control(
        GetParam(), "point lamp and emissive quad", scene,
        [&](glm::dvec3 p) {
            return lamp_irradiance(p, 2.0) + test::polygon_irradiance(p, quad, 3.0);
        },
        [](GpuScene& g) { test::scale_pick_pmf(g, 0u | LIGHT_PUNCTUAL_BIT, 1.1f); });
}

TEST_P(SeveralLights, UniformMapAndLamp) {
    Scene scene = test::plane_scene(kAlbedo, 1.f, 1.f);
    scene.punctual_lights.push_back(lamp(1.f));
    scene.environment = test::map_with_sun(64, 32, 0.4f, 0, 0, 0.4f);
    expect_exact_with_control(
        GetParam(), "uniform map and point lamp", scene,
        [&](glm::dvec3 p) { return kPi * 0.4 + lamp_irradiance(p, 1.0); },
        [](GpuScene& g) { test::scale_pick_pmf(g, 0u | LIGHT_PUNCTUAL_BIT, 1.1f); });
}

TEST_P(SeveralLights, MapSunAndDirectionalLight) {
    Scene scene = test::plane_scene(kAlbedo, 1.f, 1.f);
    PunctualLight l;
    l.kind = PunctualKind::Directional;
    l.direction = glm::normalize(glm::vec3(-0.4f, -1.f, 0.2f));
    l.intensity = glm::vec3(1.5f);
    scene.punctual_lights.push_back(l);
    scene.environment = test::map_with_sun(64, 32, 0.2f, 20, 8, 2e3f);
    const double sky = test::upward_irradiance(scene.environment);
    const double cos_t = -double(l.direction.y);
    expect_exact_with_control(
        GetParam(), "map with a sun and a directional light", scene,
        [&](glm::dvec3) { return sky + 1.5 * cos_t; },
        [](GpuScene& g) { test::scale_pick_pmf(g, 0u | LIGHT_PUNCTUAL_BIT, 1.1f); });
}

// An emissive sphere, two emissive quads and a point lamp, all picked through the light tree:
// exact per pixel (a sphere of radiance L wholly above the horizon gives pi L (R/d)^2 cos).
// Control, on both APIs: the sphere's trail in the tree swapped with a quad triangle's, so
// the tree's pmf is wrong where emitter_hit_pdf alone reads it (the MIS weight of BSDF
// samples that hit a light; next-event estimation walks the tree without trails).
TEST_P(SeveralLights, SphereQuadsAndLampThroughTheTree) {
    Scene scene = test::plane_scene(kAlbedo, 1.f, 1.f);
    scene.punctual_lights.push_back(lamp(0.5f));
    Material m;
    m.color = glm::vec3(0.f);
    m.emission = glm::vec3(3.f);
    const uint32_t quad_mat = uint32_t(scene.add_material(m));
    const auto add_quad = [&](glm::vec3 a, glm::vec3 b, glm::vec3 c, glm::vec3 d) {
        scene.triangles.push_back({a, b, c, quad_mat});
        scene.triangles.push_back({a, c, d, quad_mat});
        return std::vector<glm::dvec3>{a, b, c, d};
    };
    const auto quad1 =
        add_quad({1.2f, 1.2f, -0.5f}, {2.2f, 1.2f, -0.5f}, {2.2f, 1.2f, 0.5f}, {1.2f, 1.2f, 0.5f});
    const auto quad2 =
        add_quad({-0.5f, 1.1f, 1.2f}, {0.5f, 1.1f, 1.2f}, {0.5f, 1.1f, 2.2f}, {-0.5f, 1.1f, 2.2f});
    m.emission = glm::vec3(4.f);
    const glm::dvec3 centre(-1.5, 1.3, 0.3);
    const double radius = 0.25;
    scene.spheres.push_back({glm::vec3(centre), float(radius), uint32_t(scene.add_material(m))});
    scene.light_tree = true;
    const auto irradiance = [&](glm::dvec3 p) {
        const glm::dvec3 to_c = centre - p;
        const double d = glm::length(to_c);
        return lamp_irradiance(p, 0.5) + test::polygon_irradiance(p, quad1, 3.0) +
               test::polygon_irradiance(p, quad2, 3.0) +
               kPi * 4.0 * (radius * radius) / (d * d) * (to_c.y / d);
    };
    const std::vector<double> exact = test::expected_image(
        scene, kSize, [&](glm::dvec3 p) { return kAlbedo / kPi * irradiance(p); });
    const std::string api = GetParam();
    test::CaseRender how;
    const RenderResult r = test::render_case(api, scene, kSize, how);
    how.plant = [](GpuScene& g) {
        // (prim, trail) pairs sorted by prim: the sphere's (the last) and triangle 2's.
        const uint32_t at = g.params.light_trails_word, n = g.params.num_light_trails;
        uint32_t sphere = n, triangle = n;
        for (uint32_t i = 0; i < n; ++i) {
            if (g.texels.at(at + 2 * i) == (0u | LIGHT_SPHERE_BIT)) sphere = i;
            if (g.texels.at(at + 2 * i) == 2u) triangle = i;
        }
        if (sphere == n || triangle == n) throw std::runtime_error("no trail to swap");
        std::swap(g.texels.at(at + 2 * sphere + 1), g.texels.at(at + 2 * triangle + 1));
    };
    const RenderResult planted = test::render_case(api, scene, kSize, how);
    const int off = test::pixels_off(r, exact);
    const double z = test::image_z(r, exact), planted_z = test::image_z(planted, exact);
    std::printf(
        "%s, sphere, quads and lamp through the tree: %d of %d pixels off, image z %.2f; "
        "a sphere's trail swapped: z %.1f, %d pixels off\n",
        api.c_str(), off, kSize * kSize, z, planted_z, test::pixels_off(planted, exact));
    EXPECT_EQ(r.nonfinite_total, 0u);
    EXPECT_EQ(off, 0) << api;
    EXPECT_LT(std::abs(z), 4.5) << api;
    EXPECT_GT(std::abs(planted_z), 4.5) << api << ": a wrong pmf in the MIS weight passed";
}

// Lamps only (two point lamps and a directional light): exact per pixel whether picked by
// power, by the tree or by contribution, and by contribution with a hundredth of the variance
// of either or less (the unshadowed light is exact, and nothing casts a shadow: what is left
// is the light's change across a pixel). Control (OpenCL): the first lamp's pmf 10% off, the pick
// unchanged.
TEST_P(SeveralLights, LampsByContribution) {
    Scene scene = test::plane_scene(kAlbedo, 1.f, 1.f);
    scene.punctual_lights.push_back(lamp(2.f));
    PunctualLight side = lamp(1.f);
    side.position = glm::vec3(1.5f, 0.8f, -0.5f);
    scene.punctual_lights.push_back(side);
    PunctualLight sun;
    sun.kind = PunctualKind::Directional;
    sun.direction = glm::normalize(glm::vec3(-0.4f, -1.f, 0.2f));
    sun.intensity = glm::vec3(1.5f);
    scene.punctual_lights.push_back(sun);
    ASSERT_TRUE(scene.auto_light_by_contribution());
    const auto irradiance = [&](glm::dvec3 p) {
        const glm::dvec3 to_side = glm::dvec3(side.position) - p;
        const double r = glm::length(to_side);
        return lamp_irradiance(p, 2.0) + to_side.y / (r * r * r) - 1.5 * double(sun.direction.y);
    };
    const std::vector<double> exact = test::expected_image(
        scene, kSize, [&](glm::dvec3 p) { return kAlbedo / kPi * irradiance(p); });
    const std::string api = GetParam();
    double variance[3] = {};
    for (int mode = 0; mode < 3; ++mode) {
        Scene s = scene;
        s.light_tree = mode == 1;
        s.light_by_contribution = mode == 2;
        const char* what = mode == 0 ? "power" : mode == 1 ? "tree" : "contribution";
        const RenderResult r = test::render_case(api, s, kSize);
        const int off = test::pixels_off(r, exact);
        const double z = test::image_z(r, exact);
        variance[mode] = test::mean_sample_variance(r);
        std::printf("%s, lamps by %s: %d of %d pixels off, image z %.2f, mean variance %.3g\n",
                    api.c_str(), what, off, kSize * kSize, z, variance[mode]);
        EXPECT_EQ(r.nonfinite_total, 0u) << what;
        EXPECT_EQ(off, 0) << api << ": " << what;
        EXPECT_LT(std::abs(z), 4.5) << api << ": " << what;
    }
    EXPECT_LT(variance[2], 0.01 * variance[1]) << api;  // measured: 5,000x less
    EXPECT_LT(variance[2], 0.01 * variance[0]) << api;
    if (api != "opencl") return;  // the planted pmf is an OpenCL build option
    Scene s = scene;
    s.light_by_contribution = true;
    test::CaseRender how;
    how.defines = "-DMCPT_NEGATIVE_CONTROL_CONTRIBUTION_PMF";
    const double planted_z = test::image_z(test::render_case(api, s, kSize, how), exact);
    std::printf("%s, lamps by contribution, a planted pmf: image z %.1f\n", api.c_str(), planted_z);
    EXPECT_GT(std::abs(planted_z), 4.5) << "the planted pmf passed";
}

// Lamps by contribution where the BSDF and visibility matter: two spot lamps (one cone edge
// across the view) and a point lamp over a glossy plane (roughness 0.3), a ball casting their
// shadows. No exact image: by contribution against by power, which has no weights to get
// wrong, per pixel and image-wide at about equal error bars (power at 4x the samples).
// Control (OpenCL): the first lamp's pmf 10% off, the pick unchanged.
TEST_P(SeveralLights, LampsByContributionOnAGlossyShadowedPlane) {
    Scene scene = test::plane_scene(kAlbedo, 1.f, 1.f);
    Material& plane = scene.materials[0];
    plane.type = MaterialType::Pbr;
    plane.metallic = 0.f, plane.roughness = 0.3f;
    plane.color = glm::vec3(kAlbedo);
    Material ball;
    ball.color = glm::vec3(0.6f);
    scene.spheres.push_back(
        {glm::vec3(0.25f, 0.35f, 0.1f), 0.2f, uint32_t(scene.add_material(ball))});
    PunctualLight spot;
    spot.kind = PunctualKind::Spot;
    spot.position = glm::vec3(-0.9f, 1.2f, -0.4f);
    spot.direction = glm::normalize(glm::vec3(0.2f, 0.f, 0.1f) - spot.position);
    spot.inner_cone = 0.25f, spot.outer_cone = 0.45f;
    spot.intensity = glm::vec3(3.f);
    scene.punctual_lights.push_back(spot);
    spot.position = glm::vec3(0.8f, 0.9f, 0.7f);
    spot.direction = glm::normalize(glm::vec3(0.f, -1.f, -0.3f));
    spot.inner_cone = 0.4f, spot.outer_cone = 0.6f;
    spot.intensity = glm::vec3(1.5f);
    scene.punctual_lights.push_back(spot);
    scene.punctual_lights.push_back(lamp(0.7f));
    scene.punctual_lights.back().position = glm::vec3(0.1f, 1.4f, 0.9f);
    ASSERT_TRUE(scene.auto_light_by_contribution());
    const std::string api = GetParam();
    Scene by_power = scene, by_contribution = scene;
    by_power.light_by_contribution = false;
    by_contribution.light_by_contribution = true;
    test::CaseRender how;
    how.spp = 1024;
    const RenderResult power = test::render_case(api, by_power, kSize, how);
    how.spp = 256;
    const RenderResult contribution = test::render_case(api, by_contribution, kSize, how);
    const test::MeanEstimate p = test::pooled_mean(power), c = test::pooled_mean(contribution);
    const double z = (c.mean - p.mean) / std::hypot(p.std_error, c.std_error);
    const int apart = test::pixels_apart(contribution, power);
    std::printf(
        "%s, spots, lamp, glossy plane, ball: contribution %.5f +- %.5f, power %.5f +- "
        "%.5f, z %.2f, %d pixels apart\n",
        api.c_str(), c.mean, c.std_error, p.mean, p.std_error, z, apart);
    EXPECT_EQ(contribution.nonfinite_total + power.nonfinite_total, 0u);
    EXPECT_LT(std::abs(z), 4.5) << api;
    EXPECT_EQ(apart, 0) << api;
    if (api != "opencl") return;  // the planted pmf is an OpenCL build option
    how.defines = "-DMCPT_NEGATIVE_CONTROL_CONTRIBUTION_PMF";
    const test::MeanEstimate planted =
        test::pooled_mean(test::render_case(api, by_contribution, kSize, how));
    const double planted_z = (planted.mean - p.mean) / std::hypot(p.std_error, planted.std_error);
    std::printf("%s, a planted pmf: z %.1f\n", api.c_str(), planted_z);
    EXPECT_GT(std::abs(planted_z), 4.5) << "the planted pmf passed";
}

INSTANTIATE_TEST_SUITE_P(Api, SeveralLights, ::testing::ValuesIn(test::test_apis()),
                         [](const auto& info) { return info.param; });

}  // namespace
}  // namespace mcpt
