// The light tree (common/render/light_tree.h, common/gpu/light_tree.h): at shading points of a
// scene of many small emitters and lamps, the device code's pick (compiled for the CPU) against
// its pmf by chi-square, the pmf summed over every light is 1, a light's pmf by its trail is
// the pick's; and renders with the tree exact where the lights' radiance is known.
#include "common/gpu/light_tree.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "common/accel/kdtree.h"
#include "common/analysis/stats.h"
#include "common/render/gpu_scene.h"
#include "light_cases.h"
#include "test_util.h"

namespace mcpt {
namespace {

// A floor plan of n emissive quads (two triangles each) of different powers and a few lamps.
Scene many_lights(int n, uint32_t seed) {
    Scene scene = test::plane_scene(0.5f, 10.f, 1.f);
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> pos(-9.f, 9.f), power(0.2f, 5.f);
    for (int i = 0; i < n; ++i) {
        Material m;
        m.color = glm::vec3(0.f);
        m.emission = glm::vec3(power(rng));
        const uint32_t mat = scene.add_material(m);
        const glm::vec3 c(pos(rng), 0.5f, pos(rng));
        const glm::vec3 a = c + glm::vec3(-0.1f, 0, -0.1f), b = c + glm::vec3(0.1f, 0, -0.1f),
                        d = c + glm::vec3(0.1f, 0, 0.1f), e = c + glm::vec3(-0.1f, 0, 0.1f);
        scene.triangles.push_back({a, b, d, mat});  // facing down
        scene.triangles.push_back({a, d, e, mat});
    }
    for (int i = 0; i < n; ++i) {  // as many small lamps, low over the floor
        PunctualLight l;
        l.kind = PunctualKind::Point;
        l.position = glm::vec3(pos(rng), 0.3f, pos(rng));
        l.intensity = glm::vec3(0.02f * power(rng));
        scene.punctual_lights.push_back(l);
    }
    scene.light_tree = true;
    return scene;
}

#define TREE_ARGS &g.params, nullptr, nullptr, nullptr, nullptr, nullptr, nullptr, nullptr, nullptr, g.texels.data(),

TEST(LightTree, PicksFollowTheirPmfAndSumToOne) {
    const Scene scene = many_lights(100, 3);
    const GpuScene g = pack_scene(scene, build_kdtree(scene.triangles, TreeOptions{}));
    ASSERT_EQ(g.params.num_tree_lights, 300u);
    ASSERT_EQ(g.lights.size(), 300u);
    std::mt19937 rng(9);
    std::uniform_real_distribution<float> u01(0.f, 1.f), pos(-10.f, 10.f);
    for (int k = 0; k < 4; ++k) {
        const glm::vec3 x(pos(rng), 0.f, pos(rng));
        // pmf of every light by its trail; their sum.
        std::vector<double> expected(g.lights.size(), 0.0);
        double sum = 0;
        for (size_t slot = 0; slot < g.lights.size(); ++slot) {
            const uint32_t trail = gpu::light_tree_trail(TREE_ARGS g.lights[slot].prim);
            ASSERT_NE(trail, NO_HIT) << slot;
            expected[slot] = gpu::light_tree_pmf(TREE_ARGS x, trail);
            ASSERT_GT(expected[slot], 0.0) << slot;
            sum += expected[slot];
        }
        EXPECT_NEAR(sum, 1.0, 1e-5) << "at " << x.x << ", " << x.z;
        // Picks against it; each pick's pmf is its light's.
        constexpr int kPicks = 200000;
        std::vector<double> observed(g.lights.size(), 0.0);
        for (int i = 0; i < kPicks; ++i) {
            const gpu::TreePick p = gpu::light_tree_pick(TREE_ARGS x, u01(rng));
            ASSERT_LT(p.slot, g.lights.size());
            ASSERT_FLOAT_EQ(p.pmf, float(expected[p.slot]));
            observed[p.slot] += 1;
        }
        for (double& e : expected) e *= kPicks;
        const double p_value = stats::chi_square_test(observed, expected);
        std::printf("light tree at (%.1f, %.1f): sum of pmf %.6f, chi-square p = %.3f\n", x.x, x.z,
                    sum, p_value);
        EXPECT_GT(p_value, 1e-3);
    }
}

// Mean over pixels of one sample's variance (channel 0).
double sample_variance(const RenderResult& r) {
    double v = 0;
    for (size_t i = 0; i < r.nonfinite.size(); ++i) {
        const double n = double(r.spp), mean = r.sum[3 * i] / n;
        v += std::max(0.0, r.sum_sq[3 * i] / n - mean * mean) * n / (n - 1);
    }
    return v / double(r.nonfinite.size());
}

class LightTreeRender : public ::testing::TestWithParam<std::string> {};

// Many lights over a floor plan: the tree's pick beats power alone per sample by at least
// 2x (the same image in expectation: the means agree).
TEST_P(LightTreeRender, ManyLightsBeatPowerAlonePerSample) {
    Scene scene = many_lights(200, 5);
    test::CaseRender how;
    how.spp = 64;
    const RenderResult tree = test::render_case(GetParam(), scene, 32, how);
    scene.light_tree = false;
    const RenderResult power = test::render_case(GetParam(), scene, 32, how);
    const double vt = sample_variance(tree), vp = sample_variance(power);
    const test::MeanEstimate mt = test::pooled_mean(tree), mp = test::pooled_mean(power);
    std::printf("%s, 200 quads and 200 lamps: variance per sample, power %.4g, tree %.4g: %.2fx; "
                "means %.5f and %.5f (z %.2f)\n",
                GetParam().c_str(), vp, vt, vp / vt, mp.mean, mt.mean,
                (mt.mean - mp.mean) / std::hypot(mt.std_error, mp.std_error));
    EXPECT_GT(vp / vt, 2.0);
    EXPECT_LT(std::abs(mt.mean - mp.mean) / std::hypot(mt.std_error, mp.std_error), 4.5);
}

INSTANTIATE_TEST_SUITE_P(Api, LightTreeRender, ::testing::ValuesIn(test::test_apis()),
                         [](const auto& info) { return info.param; });

}  // namespace
}  // namespace mcpt
