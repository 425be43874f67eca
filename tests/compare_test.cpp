// OpenCL (PoCL in CI) against Vulkan (lavapipe in CI): the images agree statistically on
// scenes with glass and mirrors, the furnace and a deep mesh tree; the same test rejects a
// light 2% brighter in one backend and a variant that drops refraction through glass.
#include "common/analysis/compare.h"

#include <gtest/gtest.h>

#include "common/render/device_registry.h"
#include "test_scenes.h"
#include "test_util.h"

namespace mcpt {
namespace {

struct Case {
    Scene scene;
    GpuScene gpu;
    RenderOptions options;
};

Case make_case(Scene scene) {
    validate_scene(scene);
    Case c{scene, pack_scene(scene, build_kdtree(scene.triangles, TreeOptions{})), {}};
    c.options.width = 32, c.options.height = 32;
    c.options.max_depth = scene.max_depth_hint > 0 ? uint32_t(scene.max_depth_hint) : 8u;
    return c;
}

// Vulkan is part of the build: a missing device fails the test (install-deps brings lavapipe).
std::unique_ptr<Backend> vulkan_backend() {
    return open_device("vulkan", BackendOptions{});
}

// A on OpenCL, B on Vulkan, independent seeds; returns the agreement.
Agreement compare(const Case& c, const std::string& a_defines = "", float b_light_scale = 1.f) {
    auto a = test::test_opencl_backend(a_defines);
    auto b = vulkan_backend();
    BatchOptions bo;
    bo.batches = 32;
    bo.spp_per_batch = 8;
    bo.seed_base = 100;
    const BatchSet sa = render_batches(*a, c.gpu, c.scene.camera, c.options, bo);
    RenderOptions ob = c.options;
    ob.light_scale = b_light_scale;
    bo.seed_base = 5000;
    const BatchSet sb = render_batches(*b, c.gpu, c.scene.camera, ob, bo);
    const Agreement g = test_agreement(sa, sb, 0.01);
    std::printf("%s\n", g.verdict().c_str());
    ::testing::Test::RecordProperty("detectable_bias_percent",
                                    std::to_string(100 * g.detectable_bias));
    return g;
}

TEST(CompareBackends, CornellAgrees) {
    const Agreement g = compare(make_case(make_builtin_scene("cornell")));
    EXPECT_TRUE(g.agree) << g.verdict();
    EXPECT_LT(g.detectable_bias, 0.01) << "the test must be able to see a 1% bias";
}

TEST(CompareBackends, FurnaceAgrees) {
    const Agreement g = compare(make_case(make_furnace_scene(0.8f, 1.f)));
    EXPECT_TRUE(g.agree) << g.verdict();
}

TEST(CompareBackends, DeepMeshTreeAgrees) {
    const Case c = make_case(make_bumpy_sphere_scene(100));
    EXPECT_GE(c.gpu.tree_stats.max_depth, 18);
    const Agreement g = compare(c);
    EXPECT_TRUE(g.agree) << g.verdict();
}

TEST(CompareBackends, RejectsTwoPercentBrighterLight) {
    const Agreement g = compare(make_case(make_builtin_scene("cornell")), "", 1.02f);
    EXPECT_FALSE(g.agree) << g.verdict();
    EXPECT_GT(g.mean_z_score, g.global_z_limit);
}

TEST(CompareBackends, RejectsDroppedRefraction) {
    const Agreement g =
        compare(make_case(make_builtin_scene("cornell")), "-DMCPT_NEGATIVE_CONTROL_NO_REFRACTION");
    EXPECT_FALSE(g.agree) << g.verdict();
    EXPECT_GT(g.bh_discoveries, 0u) << "the missing caustic should be localized";
}

}  // namespace
}  // namespace mcpt

namespace mcpt {
namespace {

// OpenCL on GPUs reads triangles as 64-bit words (-DMCPT_TRIANGLE_WORDS): on the CPU device
// in CI that build renders exactly the image of the plain struct read, same seed.
TEST(OpenClTriangleWords, SameImageAsStructReads) {
    Scene scene = make_bumpy_sphere_scene(12);
    validate_scene(scene);
    const GpuScene g = pack_scene(scene, build_kdtree(scene.triangles, TreeOptions{}));
    RenderOptions o;
    o.width = o.height = 16;
    o.spp = 4;
    o.seed = 7;
    auto plain = test::test_opencl_backend();
    auto words = test::test_opencl_backend("-DMCPT_TRIANGLE_WORDS");
    const SameSeedDiff d =
        same_seed_diff(render(*plain, g, scene.camera, o), render(*words, g, scene.camera, o));
    EXPECT_EQ(d.diverged, 0u);
    EXPECT_EQ(d.max_abs_diff, 0.0);
}

}  // namespace
}  // namespace mcpt
