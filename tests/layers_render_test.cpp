// Clearcoat and sheen (common/gpu/layers.h) rendered on both APIs, against the exact radiance:
// a large plane seen at 60 degrees from its normal through a narrow camera, under a uniform
// sky of radiance 1, one scattering vertex: each pixel's expected radiance is the material's
// directional albedo at that angle, the integral of f cos over the hemisphere, here by
// quadrature of the same device functions on the CPU. A coat only (the build without the
// sheen) and both layers. Control: the sheen's colour or the coat's weight 10 % higher on the
// device is rejected.
#include <gtest/gtest.h>

#include <cmath>
#include <functional>

#include "bsdf_checks.h"
#include "light_cases.h"
#include "test_util.h"

namespace mcpt {
namespace {

constexpr float kCosView = 0.5f;

struct Layers {
    const char* name;
    float clearcoat, coat_roughness;
    glm::vec3 sheen;
    float sheen_roughness;
};
const Layers kLayers[] = {{"coat", 1.f, 0.3f, glm::vec3(0.f), 0.f},
                          {"coat_and_sheen", 0.7f, 0.4f, glm::vec3(0.5f, 0.8f, 1.f), 0.5f}};

Material material(const Layers& l) {
    Material m;
    m.type = MaterialType::Pbr;
    m.color = glm::vec3(0.7f, 0.2f, 0.1f);
    m.roughness = 0.5f;
    m.clearcoat = l.clearcoat, m.clearcoat_roughness = l.coat_roughness;
    m.sheen_color = l.sheen, m.sheen_roughness = l.sheen_roughness;
    return m;
}

Scene plane(const Layers& l) {
    Scene s;
    const uint32_t mat = s.add_material(material(l));
    const float r = 1000.f;
    s.triangles.push_back({{-r, -r, 0}, {r, -r, 0}, {r, r, 0}, mat});
    s.triangles.push_back({{-r, -r, 0}, {r, r, 0}, {-r, r, 0}, mat});
    const float sin_view = std::sqrt(1 - kCosView * kCosView);
    s.camera.position = glm::vec3(sin_view, 0, kCosView) * 10.f;
    s.camera.forward = -glm::normalize(s.camera.position);
    s.camera.up = {0, 1, 0};
    s.camera.yfov = 0.02f;  // rays within 0.01 rad of the view direction
    s.has_camera = true;
    s.environment = test::map_with_sun(8, 4, 1.f, 0, 0, 1.f);
    return s;
}

// The albedo of the packed material at kCosView, channel c, by quadrature.
double exact(const Layers& l, int c) {
    const gpu::GpuMaterial m = pack_material(material(l));
    const gpu::vec3 wo = gpu::outgoing(kCosView);
    return gpu::hemisphere_integral(
        [&](gpu::vec3 wi) { return double(gpu::coated_eval(m, wo, wi).f[c]) * wi.z; }, 900, 400);
}

class LayersRender : public ::testing::TestWithParam<std::tuple<std::string, int>> {};

TEST_P(LayersRender, PlaneUnderAUniformSkyIsItsAlbedoAndTenPercentMoreIsRejected) {
    const auto& [api, which] = GetParam();
    const Layers& l = kLayers[which];
    test::CaseRender how;
    how.spp = 64;
    how.max_depth = 1;
    const RenderResult r = test::render_case(api, plane(l), 16, how);
    EXPECT_EQ(r.nonfinite_total, 0u);
    for (int c = 0; c < 3; ++c) {
        const test::ChannelMean m = test::channel_mean(r, c);
        const double e = exact(l, c);
        // (0.2 % for the quadrature and the view's 0.01 rad spread)
        EXPECT_LT(std::abs(m.mean - e), 4.5 * m.std_error + 2e-3 * e)
            << api << " " << l.name << " channel " << c << ": " << m.mean << " +- " << m.std_error
            << " against " << e;
        std::printf("%s %s channel %d: %.5f +- %.5f, exact %.5f\n", api.c_str(), l.name, c, m.mean,
                    m.std_error, e);
    }
    // Control: the layer 10 % stronger on the device only.
    how.plant = [&](GpuScene& g) {
        for (gpu::GpuMaterial& m : g.materials) {
            if (l.sheen.x > 0)
                m.sheen_r *= 1.1f, m.sheen_g *= 1.1f, m.sheen_b *= 1.1f;
            else
                m.clearcoat *= 1.1f;
        }
    };
    const RenderResult bad = test::render_case(api, plane(l), 16, how);
    const test::ChannelMean m = test::channel_mean(bad, 2);
    EXPECT_GT(std::abs(m.mean - exact(l, 2)), 4.5 * m.std_error + 2e-3 * exact(l, 2))
        << api << " " << l.name << ": a layer 10% stronger went unnoticed";
}

INSTANTIATE_TEST_SUITE_P(Apis, LayersRender,
                         ::testing::Combine(::testing::ValuesIn(test::test_apis()),
                                            ::testing::Values(0, 1)),
                         [](const auto& info) {
                             return std::get<0>(info.param) + "_" +
                                    kLayers[std::get<1>(info.param)].name;
                         });

}  // namespace
}  // namespace mcpt
