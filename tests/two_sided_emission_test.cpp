// Emission from both faces of a triangle (glTF doubleSided), on both APIs: a Lambertian plane
// lit by a square emitter that faces away from it and a one-sided one beside it, exact per
// pixel (Lambert's polygon irradiance), by power (a two-sided face counts twice) and through
// the light tree (its pick and pmf, MIS at the back face). Controls: a 2% brighter light is
// caught; with the square one-sided, the image is the other emitter's light alone.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "light_cases.h"
#include "test_util.h"

namespace mcpt {
namespace {

constexpr float kAlbedo = 0.5f;
constexpr float kRadiance = 3.f;  // the two-sided square's
constexpr float kBeside = 5.f;    // the one-sided rectangle's
constexpr float kHeight = 4.f;    // above the camera (at 3): it never sees the emitters

// Corners, counter-clockwise seen from above: the square over the plane y = 0 (its front
// faces up, away from the plane, so only its back can light it) and a rectangle beside it.
const glm::vec3 kSquare[4] = {
    {-1, kHeight, -1}, {-1, kHeight, 1}, {1, kHeight, 1}, {1, kHeight, -1}};
const glm::vec3 kRect[4] = {
    {1.5f, kHeight, -0.5f}, {1.5f, kHeight, 0.5f}, {2, kHeight, 0.5f}, {2, kHeight, -0.5f}};

// The plane (seen from above) lit by the square's back, two-sided or not, and by the
// rectangle's front, facing down (one-sided: a scene of both kinds, their powers counted per
// face in the pick by power).
Scene emitters_over_plane(bool two_sided) {
    Scene scene = test::plane_scene(kAlbedo, 1.f, 1.f);
    const auto add = [&](const glm::vec3* v, float radiance, bool both, bool facing_down) {
        Material lamp;
        lamp.color = glm::vec3(0.f);
        lamp.emission = glm::vec3(radiance);
        lamp.two_sided = both;
        const uint32_t m = scene.add_material(lamp);
        if (facing_down) {
            scene.triangles.push_back({v[0], v[2], v[1], m});
            scene.triangles.push_back({v[0], v[3], v[2], m});
        } else {
            scene.triangles.push_back({v[0], v[1], v[2], m});
            scene.triangles.push_back({v[0], v[2], v[3], m});
        }
    };
    add(kSquare, kRadiance, two_sided, false);
    add(kRect, kBeside, false, true);
    return scene;
}

// Irradiance at p (normal +y) from a Lambertian polygon of radiance L (Lambert's formula:
// L / 2 times the sum over edges of the angle they subtend times the cosine of their plane).
double polygon_irradiance(glm::dvec3 p, const glm::vec3* v, double radiance) {
    double sum = 0;
    for (int i = 0; i < 4; ++i) {
        const glm::dvec3 a = glm::normalize(glm::dvec3(v[i]) - p);
        const glm::dvec3 b = glm::normalize(glm::dvec3(v[(i + 1) % 4]) - p);
        const double angle = std::acos(std::clamp(glm::dot(a, b), -1.0, 1.0));
        sum += angle * glm::normalize(glm::cross(a, b)).y;
    }
    return radiance / 2 * std::abs(sum);
}

class TwoSidedEmission : public ::testing::TestWithParam<std::string> {};

TEST_P(TwoSidedEmission, BackFaceLightsThePlaneExactly) {
    const std::string api = GetParam();
    constexpr int kSize = 24;
    const Scene scene = emitters_over_plane(true);
    const auto image = [&](bool square) {
        return test::expected_image(scene, kSize, [&](glm::dvec3 p) {
            return kAlbedo / test::kPi *
                   ((square ? polygon_irradiance(p, kSquare, kRadiance) : 0.0) +
                    polygon_irradiance(p, kRect, kBeside));
        });
    };
    const std::vector<double> exact = image(true);
    test::CaseRender how;
    how.spp = 256;
    for (bool tree : {false, true}) {
        Scene s = scene;
        s.light_tree = tree;
        const char* by = tree ? "the tree" : "power";
        const RenderResult r = test::render_case(api, s, kSize, how);
        const int off = test::pixels_off(r, exact);
        const double z = test::image_z(r, exact);
        test::CaseRender bright = how;
        bright.light_scale = 1.02f;
        const double bright_z = test::image_z(test::render_case(api, s, kSize, bright), exact);
        std::printf("%s, %s: %d of %d pixels off, image z %.2f; 2%% brighter: z %.1f\n",
                    api.c_str(), by, off, kSize * kSize, z, bright_z);
        EXPECT_EQ(r.nonfinite_total, 0u) << api << ", " << by;
        EXPECT_EQ(off, 0) << api << ", " << by;
        EXPECT_LT(std::abs(z), 4.5) << api << ", " << by;
        EXPECT_GT(bright_z, 4.5) << api << ", " << by << ": control passed";
    }
    // Control: with the square one-sided its back is dark: the rectangle's light alone.
    const RenderResult one = test::render_case(api, emitters_over_plane(false), kSize, how);
    const double z_one = test::image_z(one, image(false)), z_both = test::image_z(one, exact);
    std::printf(
        "%s, the square one-sided: image z %.2f against the rectangle's light alone, "
        "%.1f against both\n",
        api.c_str(), z_one, z_both);
    EXPECT_EQ(test::pixels_off(one, image(false)), 0) << api;
    EXPECT_LT(std::abs(z_one), 4.5) << api;
    EXPECT_LT(z_both, -4.5) << api << ": a one-sided square lit the plane from its back";
}

INSTANTIATE_TEST_SUITE_P(Api, TwoSidedEmission, ::testing::ValuesIn(test::test_apis()),
                         [](const auto& info) { return info.param; });

}  // namespace
}  // namespace mcpt
