// Absorbing glass (KHR_materials_volume) on both APIs, against the exact radiance: a glass slab
// of thickness d seen head-on through a narrow camera, with a uniform background of radiance 1
// all around. Every path ends in the background, so the pixel is R + T^2 tau / (1 - R tau)
// with tau = exp(-sigma d) and R = 1 - T the Fresnel reflectance at normal incidence (the
// front face's reflection, the light through, and each internal reflection that leaves by
// either face). The channels absorb sigma / 3, sigma and nothing (then exactly 1: glass alone
// loses no light). Control: the attenuation distance x 1.05 (sigma / 1.05) is rejected.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "light_cases.h"
#include "test_util.h"

namespace mcpt {
namespace {

constexpr float kIor = 1.5f, kThickness = 0.5f;
const float kSigma = std::log(4.f) / kThickness;  // tau = 1/4 in the middle channel

// The box [lo, hi] as twelve triangles facing out.
void add_box(Scene& s, glm::vec3 lo, glm::vec3 hi, uint32_t material) {
    const auto corner = [&](int i) {
        return glm::vec3(i & 1 ? hi.x : lo.x, i & 2 ? hi.y : lo.y, i & 4 ? hi.z : lo.z);
    };
    // Each face's corners counter-clockwise seen from outside.
    const int faces[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4},
                             {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
    for (const auto& f : faces) {
        s.triangles.push_back({corner(f[0]), corner(f[1]), corner(f[2]), material});
        s.triangles.push_back({corner(f[0]), corner(f[2]), corner(f[3]), material});
    }
}

Scene slab(float sigma) {
    Scene s;
    Material glass;
    glass.type = MaterialType::Glass;
    glass.color = glm::vec3(1.f);
    glass.ior = kIor;
    glass.absorption = glm::vec3(sigma / 3.f, sigma, 0.f);
    add_box(s, {-2, -2, -kThickness / 2}, {2, 2, kThickness / 2}, s.add_material(glass));
    s.camera.position = {0, 0, 10};
    s.camera.forward = {0, 0, -1};
    s.camera.up = {0, 1, 0};
    s.camera.yfov = 0.02f;  // rays within 0.01 rad of the normal
    s.has_camera = true;
    s.environment = test::map_with_sun(8, 4, 1.f, 0, 0, 1.f);
    return s;
}

// The exact radiance through the slab of a channel absorbing sigma.
double exact(double sigma) {
    const double r = std::pow((kIor - 1) / (kIor + 1), 2), t = 1 - r;
    const double tau = std::exp(-sigma * kThickness);
    return r + t * t * tau / (1 - r * tau);
}

class Volume : public ::testing::TestWithParam<std::string> {};

TEST_P(Volume, SlabTransmitsExactlyAndADistanceFivePercentLongerIsRejected) {
    const std::string api = GetParam();
    test::CaseRender how;
    how.spp = 32;
    how.max_depth = 16;
    const RenderResult r = test::render_case(api, slab(kSigma), 16, how);
    EXPECT_EQ(r.nonfinite_total, 0u);
    const double sigmas[3] = {kSigma / 3, kSigma, 0};
    for (int c = 0; c < 3; ++c) {
        const test::ChannelMean m = test::channel_mean(r, c);
        EXPECT_TRUE(m.near(exact(sigmas[c])))
            << api << " channel " << c << ": " << m.mean << " against " << exact(sigmas[c])
            << ", z " << m.z(exact(sigmas[c]));
    }
    // Control: attenuationDistance x 1.05.
    const RenderResult control = test::render_case(api, slab(kSigma / 1.05f), 16, how);
    const double z = test::channel_mean(control, 1).z(exact(kSigma));
    EXPECT_GT(z, 6.0) << api << ": the control's z " << z;
}

INSTANTIATE_TEST_SUITE_P(Apis, Volume, ::testing::ValuesIn(test::test_apis()));

}  // namespace
}  // namespace mcpt
