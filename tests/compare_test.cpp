// OpenCL (PoCL in CI) against Vulkan (lavapipe in CI): the images agree statistically on
// scenes with glass and mirrors, the furnace, a deep mesh tree and metallic-roughness
// materials; the same test rejects a light 2% brighter in one backend, a variant that drops
// refraction through glass and one with rougher microfacets.
#include "common/analysis/compare.h"

#include <gtest/gtest.h>

#include "common/analysis/stats.h"
#include "common/render/device_registry.h"
#include "common/scene/gltf_loader.h"
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

// A on OpenCL with scene `a` (built with `a_defines`), B on Vulkan with scene `b` (the same
// geometry; its lights scaled by `b_light_scale`), independent seeds; returns the agreement.
Agreement compare_scenes(const Case& a, const Case& b, const std::string& a_defines = "",
                         float b_light_scale = 1.f) {
    auto da = test::test_opencl_backend(a_defines);
    auto db = vulkan_backend();
    BatchOptions bo;
    bo.batches = 32;
    bo.spp_per_batch = 8;
    bo.seed_base = 100;
    const BatchSet sa = render_batches(*da, a.gpu, a.scene.camera, a.options, bo);
    RenderOptions ob = b.options;
    ob.light_scale = b_light_scale;
    bo.seed_base = 5000;
    const BatchSet sb = render_batches(*db, b.gpu, b.scene.camera, ob, bo);
    const Agreement g = test_agreement(sa, sb, 0.01);
    std::printf("%s\n", g.verdict().c_str());
    ::testing::Test::RecordProperty("detectable_bias_percent",
                                    std::to_string(100 * g.detectable_bias));
    return g;
}

// The same scene on both sides.
Agreement compare(const Case& c, const std::string& a_defines = "", float b_light_scale = 1.f) {
    return compare_scenes(c, c, a_defines, b_light_scale);
}

TEST(CompareBackends, CornellAgrees) {
    const Agreement g = compare(make_case(make_builtin_scene("cornell")));
    EXPECT_TRUE(g.agree) << g.verdict();
    EXPECT_LT(g.detectable_bias, 0.015) << "the test must see a 1.5% bias with 90% power";
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

TEST(CompareBackends, MetallicRoughnessAgrees) {
    const Agreement g = compare(make_case(make_builtin_scene("materials")));
    EXPECT_TRUE(g.agree) << g.verdict();
}

// A small material defect: every GGX alpha 1.1 times too large in one backend (roughness 4.9%
// higher) on the materials scene (mean z -6.2; alpha 1.05 times larger is at the edge, chi2 z
// 3.8 against a limit of 2.9).
TEST(CompareBackends, RejectsRougherMicrofacets) {
    const Agreement g = compare(make_case(make_builtin_scene("materials")),
                                "-DMCPT_NEGATIVE_CONTROL_GGX_ALPHA=1.1f");
    EXPECT_FALSE(g.agree) << g.verdict();
}

// Textures (filtering, wrap modes, sRGB), normal maps, smooth normals, an alpha mask and an
// emission texture: tests/data/textured.glb (scripts/make_textured_glb.py).
Scene textured_scene() {
    return load_gltf(std::string(MCPT_TEST_DATA_DIR) + "/textured.glb");
}

TEST(CompareBackends, TexturedSceneAgrees) {
    const Agreement g = compare(make_case(textured_scene()));
    EXPECT_TRUE(g.agree) << g.verdict();
}

// Every texel read one texel to the right in one backend: a shift of 1/64 of the checker and
// of the bumps, 1/16 of the glow.
TEST(CompareBackends, RejectsTexturesShiftedByOneTexel) {
    const Agreement g = compare(make_case(textured_scene()), "-DMCPT_NEGATIVE_CONTROL_TEXEL_SHIFT");
    EXPECT_FALSE(g.agree) << g.verdict();
}

// Lamps (tests/data/lamps.gltf: a point, a spot and a sun) and an environment map (a sky
// brightening toward +Y with a sun 1000 times brighter) on the same geometry; a lamp 2%
// brighter and an environment turned by one texel column in one backend are rejected. The
// lamps are picked as auto picks them: by their contribution.
Scene lamps_scene() {
    Scene s = load_gltf(std::string(MCPT_TEST_DATA_DIR) + "/lamps.gltf");
    s.light_by_contribution = s.auto_light_by_contribution();
    return s;
}

Scene environment_scene(float rotate_deg = 0.f) {
    Scene s = lamps_scene();
    s.punctual_lights.clear();
    s.light_by_contribution = false;
    Environment& env = s.environment;
    env.name = "sky";
    env.width = 64, env.height = 32;
    env.rgb.resize(64 * 32 * 3);
    for (int y = 0; y < 32; ++y)
        for (int x = 0; x < 64; ++x)
            for (int c = 0; c < 3; ++c)
                env.rgb[size_t((y * 64 + x) * 3 + c)] =
                    (x == 20 && y == 9)
                        ? 1000.f
                        : (0.3f + 0.7f * float(32 - y) / 32) * (c == 2 ? 1.f : 0.7f);
    env.rotate_deg = rotate_deg;
    return s;
}

TEST(CompareBackends, LampsAgree) {
    const Case c = make_case(lamps_scene());
    EXPECT_TRUE(compare(c).agree);
    EXPECT_FALSE(compare(c, "", 1.02f).agree) << "a lamp 2% brighter passed";
}

TEST(CompareBackends, EnvironmentAgrees) {
    const Case c = make_case(environment_scene());
    EXPECT_TRUE(compare(c).agree);
    const Case turned = make_case(environment_scene(360.f / 64));
    EXPECT_FALSE(compare_scenes(c, turned).agree) << "a map turned by one column passed";
}

// The same-seed check, OpenCL against Vulkan: unbiased renders diverge in at most
// kSameSeedDivergedLimit of the pixels on scenes with glass, mirrors, a furnace, a mesh, lamps
// and an environment; a light 0.2% brighter on one side (below what the statistical test sees
// in the furnace) diverges in far more, and is rejected.
TEST(CompareBackends, SameSeedCountsAndCatchesASmallBias) {
    RenderOptions o;
    o.width = o.height = 32;
    o.spp = 4;
    o.seed = 7;
    for (Scene scene : {make_builtin_scene("cornell"), make_builtin_scene("spheres"),
                        make_furnace_scene(0.8f, 1.f), make_builtin_scene("materials"),
                        textured_scene(), lamps_scene(), environment_scene()}) {
        Case c = make_case(scene);
        o.max_depth = c.options.max_depth;
        auto a = test::test_opencl_backend();
        auto b = vulkan_backend();
        const RenderResult ra = render(*a, c.gpu, c.scene.camera, o);
        const SameSeedDiff same = same_seed_diff(ra, render(*b, c.gpu, c.scene.camera, o));
        EXPECT_TRUE(same.agree()) << scene.name << ": " << same.diverged << " of " << same.pixels;
        RenderOptions brighter = o;
        brighter.light_scale = 1.002f;
        const SameSeedDiff biased =
            same_seed_diff(ra, render_loaded(*b, c.gpu, c.scene.camera, brighter));
        EXPECT_FALSE(biased.agree()) << scene.name << ": only " << biased.diverged << " of "
                                     << biased.pixels << " pixels diverged";
        EXPECT_GT(biased.fraction_diverged(), 0.3) << scene.name;
    }
}

// The power compare states, measured: a Cornell box seen without its light (every pixel's
// radiance has sampling noise, and a brighter light scales every pixel alike), rendered
// twice on one device with independent seeds, the second with its light brighter by the bias
// the unbiased comparison states as detected with 90% power. Over repeated comparisons:
//  - at that bias at least 31 of 40 detect it (fails with P = 0.5% at true power 0.9);
//  - at the bias of the old statement (the shift reaching the limit: 50% power) at most 29
//    of 40 do (fails with P = 0.3% at 0.5): the test tells 90% from 50% (negative control);
//  - without bias at most 2 of 40 raise a false alarm (alpha 0.01: fails with P = 0.8%).
// Seeds are fixed: on one device the counts are the same every run.
struct Calibration {
    Case c;
    std::unique_ptr<Backend> backend = test::test_opencl_backend();
    BatchOptions bo;

    Calibration() : c(make_case(hidden_light_cornell())) {
        c.options.width = 24, c.options.height = 20;
        c.options.max_depth = 4;
        bo.batches = 16;
        bo.spp_per_batch = 4;
    }
    static Scene hidden_light_cornell() {
        Scene s = make_builtin_scene("cornell");
        // Looking slightly down at the back wall, the floor and the spheres: the ceiling
        // light is out of view, and every ray meets the box.
        s.camera.yfov = 0.3f;
        s.camera.forward = glm::normalize(glm::vec3(0.f, -0.15f, -1.f));
        s.camera.up = glm::normalize(
            glm::cross(glm::cross(s.camera.forward, glm::vec3(0, 1, 0)), s.camera.forward));
        return s;
    }
    Agreement run(int k, float light_scale) {
        bo.seed_base = 1000u * uint32_t(2 * k + 1);
        const BatchSet a = render_batches(*backend, c.gpu, c.scene.camera, c.options, bo);
        RenderOptions ob = c.options;
        ob.light_scale = light_scale;
        bo.seed_base = 1000u * uint32_t(2 * k + 2);
        const BatchSet b = render_batches(*backend, c.gpu, c.scene.camera, ob, bo);
        return test_agreement(a, b, 0.01);
    }
    int detections(int runs, double bias, int first) {
        int n = 0;
        for (int k = 0; k < runs; ++k) n += !run(first + k, float(1 + bias)).agree;
        return n;
    }
};

TEST(CompareCalibration, StatedPowerHoldsOnAHiddenLight) {
    Calibration cal;
    // The light is not seen: no pixel is free of sampling noise.
    const Agreement unbiased = cal.run(0, 1.f);
    EXPECT_TRUE(unbiased.agree) << unbiased.verdict();
    EXPECT_GT(unbiased.pixels_tested, size_t(0.95 * 24 * 20));
    const double stated = unbiased.detectable_bias;
    const double z90 = stats::normal_quantile(kDetectionPower);
    const double half_power = stated * unbiased.global_z_limit / (unbiased.global_z_limit + z90);
    std::printf("stated: %.3f%% detected with 90%% power (50%%: %.3f%%)\n", 100 * stated,
                100 * half_power);
    ASSERT_GT(stated, 0.002);
    ASSERT_LT(stated, 0.2);
    const int at_stated = cal.detections(40, stated, 100);
    const int at_half = cal.detections(40, half_power, 200);
    const int false_alarms = cal.detections(40, 0.0, 300);
    std::printf("detected: %d/40 at the stated bias, %d/40 at the 50%% bias, %d/40 unbiased\n",
                at_stated, at_half, false_alarms);
    RecordProperty("detections_at_stated_bias", at_stated);
    EXPECT_GE(at_stated, 31) << "the stated 90% power does not hold";
    EXPECT_LE(at_half, 29) << "the calibration cannot tell 90% from 50% power";
    EXPECT_LE(false_alarms, 2) << "false alarms beyond alpha";
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
