// Stiff and extreme transport through OpenCL (PoCL in CI): long paths in bright furnaces,
// glass that must be invisible in a furnace, tiny bright lights, and non-finite samples
// that must be counted even under -cl-fast-relaxed-math.
#include <gtest/gtest.h>

#include "common/builtin_scenes.h"
#include "common/compare.h"
#include "test_util.h"

namespace mcpt {
namespace {

constexpr double kZLimit = 4.5;

RenderResult render_on_opencl(Scene scene, uint64_t spp, int size = 16,
                              const std::string& defines = "", bool fast_math = false) {
    validate_scene(scene);
    const GpuScene g = pack_scene(scene, build_kdtree(scene.triangles, TreeOptions{}));
    auto backend = test::test_opencl_backend(defines, fast_math);
    RenderOptions o;
    o.width = size, o.height = size;
    o.spp = spp;
    o.max_depth = scene.max_depth_hint > 0 ? uint32_t(scene.max_depth_hint) : 8u;
    o.seed = 3;
    return render(*backend, g, scene.camera, o);
}

void expect_furnace_exact(const Scene& scene, double exact, uint64_t spp) {
    const RenderResult r = render_on_opencl(scene, spp);
    const test::MeanEstimate e = test::pooled_mean(r);
    EXPECT_EQ(r.nonfinite_total, 0u);
    EXPECT_LT(std::abs(e.z(exact)), kZLimit)
        << "mean " << e.mean << " exact " << exact << " std error " << e.std_error;
    EXPECT_LT(e.std_error / exact, 0.01) << "too noisy to mean anything";
}

TEST(StiffTransport, FurnaceAlbedo099IsUnbiased) {
    expect_furnace_exact(make_furnace_scene(0.99f, 1.f), 100.0, 64);
}

// Long paths (about 1000 bounces): behind the "heavy" label.
TEST(StiffTransportHeavy, FurnaceAlbedo0999IsUnbiased) {
    expect_furnace_exact(make_furnace_scene(0.999f, 1.f), 1000.0, 48);
}

// A lossless glass sphere in a furnace (clear of the other objects: an emitter inside glass
// would break the uniform field) preserves the uniform radiance: it must vanish.
class GlassInFurnace : public ::testing::TestWithParam<float> {};
TEST_P(GlassInFurnace, IsInvisible) {
    Scene scene = make_furnace_scene(0.5f, 1.f);
    Material glass;
    glass.type = MaterialType::Glass;
    glass.color = glm::vec3(1.f);
    glass.ior = GetParam();
    scene.spheres.push_back({glm::vec3(0.f, 0.8f, -0.6f), 0.7f, scene.add_material(glass)});
    expect_furnace_exact(scene, 2.0, 128);
}
INSTANTIATE_TEST_SUITE_P(Ior, GlassInFurnace, ::testing::Values(1.0001f, 1.5f, 4.0f),
                         [](const auto& info) {
                             return info.param < 1.01f ? "Ior1_0001" : info.param < 2 ? "Ior1_5"
                                                                                       : "Ior4";
                         });

// A small sphere light and a 100x smaller one with 10^4x the radiance light the box alike.
TEST(StiffTransport, TinyBrightLightIsUnbiased) {
    auto scene_with_light = [](float radius) {
        Scene s = make_builtin_scene("cornell");
        Material light;
        light.color = glm::vec3(0.f);
        light.emission = glm::vec3(2.f * 0.05f * 0.05f / (radius * radius));
        s.spheres.push_back({glm::vec3(0.f, 1.5f, 0.f), radius, s.add_material(light)});
        return s;
    };
    auto batches = [](Scene s, uint32_t seed) {
        validate_scene(s);
        const GpuScene g = pack_scene(s, build_kdtree(s.triangles, TreeOptions{}));
        auto backend = test::test_opencl_backend();
        RenderOptions o;
        o.width = 16, o.height = 16;
        BatchOptions bo;
        bo.batches = 32, bo.spp_per_batch = 16, bo.seed_base = seed;
        return render_batches(*backend, g, s.camera, o, bo);
    };
    const BatchSet big = batches(scene_with_light(0.05f), 1);
    const BatchSet tiny = batches(scene_with_light(0.0005f), 5000);
    const Agreement g = test_agreement(big, tiny, 0.01);
    // Pixels seeing the light itself differ (it is smaller); the rest must not.
    EXPECT_LT(std::abs(g.mean_z_score), g.global_z_limit) << g.verdict();
    EXPECT_EQ(tiny.nonfinite, 0u);
}

// Non-finite samples are counted exactly and never reach the image, with and without
// fast-math (which may assume finite math but cannot remove an integer bit test).
class NonFinite : public ::testing::TestWithParam<bool> {};
TEST_P(NonFinite, CountedExactlyAndLeftOut) {
    const RenderResult r =
        render_on_opencl(make_builtin_scene("cornell"), 16, 4, "-DMCPT_TEST_INJECT_NAN", GetParam());
    EXPECT_EQ(r.nonfinite_total, 8u);  // pixels 0 and 1, samples 0, 4, 8, 12
    EXPECT_EQ(r.nonfinite[0], 4.0);
    EXPECT_EQ(r.nonfinite[1], 4.0);
    for (float v : r.mean_image()) EXPECT_TRUE(std::isfinite(v));
}
INSTANTIATE_TEST_SUITE_P(FastMath, NonFinite, ::testing::Bool(),
                         [](const auto& info) { return info.param ? "Relaxed" : "Strict"; });

}  // namespace
}  // namespace mcpt
