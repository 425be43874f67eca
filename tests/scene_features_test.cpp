// Leaving out what a scene does not need: the analysis finds every feature a scene uses
// (and nothing it does not), --tree auto follows the device's cost model, and kernels built
// for a scene's features render the same image as the full kernel on OpenCL and Vulkan,
// while a build that leaves out a feature the scene uses is rejected by the same test.
#include "common/render/scene_features.h"

#include <gtest/gtest.h>

#include "common/analysis/compare.h"
#include "common/render/device_registry.h"
#include "common/scene/builtin_scenes.h"
#include "test_scenes.h"
#include "test_util.h"

namespace mcpt {
namespace {

uint32_t features_of(Scene scene, TreeKind kind = TreeKind::Sah) {
    validate_scene(scene);
    TreeOptions o;
    o.kind = kind;
    return pack_scene(scene, build_kdtree(scene.triangles, o)).features;
}

Material make_material(MaterialType type, glm::vec3 emission = glm::vec3(0.f)) {
    Material m;
    m.type = type;
    m.emission = emission;
    return m;
}

// A floor quad lit by an emissive triangle or sphere, with one primitive of `extra` type.
Scene minimal_scene(bool sphere_light, bool extra_is_sphere, MaterialType extra) {
    Scene s;
    const uint32_t floor = s.add_material(make_material(MaterialType::Diffuse));
    const uint32_t light = s.add_material(make_material(MaterialType::Diffuse, glm::vec3(5.f)));
    const uint32_t other = s.add_material(make_material(extra));
    s.triangles.push_back({{-1, 0, -1}, {-1, 0, 1}, {1, 0, 1}, floor});
    if (sphere_light)
        s.spheres.push_back({{0, 2, 0}, 0.2f, light});
    else
        s.triangles.push_back({{-0.2f, 2, -0.2f}, {0.2f, 2, -0.2f}, {0, 2, 0.2f}, light});
    if (extra_is_sphere)
        s.spheres.push_back({{0, 0.5f, 0}, 0.3f, other});
    else
        s.triangles.push_back({{-0.3f, 0.5f, 0}, {0.3f, 0.5f, 0}, {0, 0.9f, 0}, other});
    return s;
}

TEST(SceneFeatures, BuiltinScenes) {
    EXPECT_EQ(features_of(make_builtin_scene("cornell")),
              FEATURE_TRIANGLES | FEATURE_SPHERES | FEATURE_DIFFUSE | FEATURE_MIRROR |
                  FEATURE_GLASS | FEATURE_RECT_LIGHTS | FEATURE_KDTREE);
    // Each triangle on its own: no rectangle.
    Scene triangles = make_builtin_scene("cornell");
    triangles.triangle_light_sampling = Scene::TriangleLightSampling::Triangles;
    EXPECT_EQ(features_of(triangles) & (FEATURE_RECT_LIGHTS | FEATURE_TRIANGLE_LIGHTS),
              FEATURE_TRIANGLE_LIGHTS);
    // The furnace's sphere emits too (and its walls are rectangles).
    EXPECT_EQ(features_of(make_builtin_scene("furnace")),
              FEATURE_TRIANGLES | FEATURE_SPHERES | FEATURE_DIFFUSE | FEATURE_RECT_LIGHTS |
                  FEATURE_SPHERE_LIGHTS | FEATURE_KDTREE);
    EXPECT_EQ(features_of(make_builtin_scene("spheres")), FEATURE_SPHERES | FEATURE_DIFFUSE |
                                                              FEATURE_MIRROR | FEATURE_GLASS |
                                                              FEATURE_SPHERE_LIGHTS);
    // No tree: no traversal.
    EXPECT_EQ(features_of(make_builtin_scene("cornell"), TreeKind::None) & FEATURE_KDTREE, 0u);
}

// Each material kind and light kind on triangles and on spheres: found exactly.
TEST(SceneFeatures, EachFeatureFoundAndNothingElse) {
    const MaterialType kinds[] = {MaterialType::Diffuse, MaterialType::Mirror, MaterialType::Glass};
    const uint32_t kind_bit[] = {FEATURE_DIFFUSE, FEATURE_MIRROR, FEATURE_GLASS};
    for (bool sphere_light : {false, true}) {
        for (bool extra_is_sphere : {false, true}) {
            for (int k = 0; k < 3; ++k) {
                const uint32_t want =
                    FEATURE_TRIANGLES | FEATURE_DIFFUSE | kind_bit[k] |
                    (sphere_light ? FEATURE_SPHERE_LIGHTS : FEATURE_TRIANGLE_LIGHTS) |
                    (sphere_light || extra_is_sphere ? FEATURE_SPHERES : 0u);
                const Scene s = minimal_scene(sphere_light, extra_is_sphere, kinds[k]);
                EXPECT_EQ(features_of(s, TreeKind::None), want)
                    << feature_names(features_of(s, TreeKind::None)) << " instead of "
                    << feature_names(want);
            }
        }
    }
}

// Clearcoat and sheen on metallic-roughness: each its own bit (and textures where a layer has
// one); on glass they are not read, so no bit.
TEST(SceneFeatures, LayersFoundEachOnItsOwn) {
    const auto with_layers = [](MaterialType type, float clearcoat, float sheen, int texture) {
        Scene s = minimal_scene(false, false, type);
        Material& m = s.materials[2];
        m.clearcoat = clearcoat;
        m.sheen_color = glm::vec3(sheen);
        m.tex_sheen_roughness = texture;
        if (texture >= 0) s.textures.push_back({"t", 1, 1, std::vector<uint16_t>(4, 0)});
        return features_of(s, TreeKind::None);
    };
    const uint32_t layers = FEATURE_CLEARCOAT | FEATURE_SHEEN;
    EXPECT_EQ(with_layers(MaterialType::Pbr, 1.f, 0.f, -1) & layers, FEATURE_CLEARCOAT);
    EXPECT_EQ(with_layers(MaterialType::Pbr, 0.f, 0.5f, -1) & layers, FEATURE_SHEEN);
    EXPECT_EQ(with_layers(MaterialType::Pbr, 0.f, 0.5f, 0) & (layers | FEATURE_TEXTURES),
              FEATURE_SHEEN | FEATURE_TEXTURES);
    EXPECT_EQ(with_layers(MaterialType::Glass, 1.f, 0.5f, 0) & (layers | FEATURE_TEXTURES), 0u);
    EXPECT_EQ(with_layers(MaterialType::Pbr, 0.f, 0.f, -1) & layers, 0u);
}

TEST(SceneFeatures, UnusedMaterialsAreLeftOut) {
    Scene s = make_builtin_scene("cornell");
    s.spheres.clear();  // glass and mirror materials stay defined, but nothing uses them
    const uint32_t f = features_of(s);
    EXPECT_EQ(f & (FEATURE_GLASS | FEATURE_MIRROR | FEATURE_SPHERES), 0u) << feature_names(f);
    EXPECT_EQ(features_left_out(FEATURE_ALL), "nothing (the scene uses every feature)");
    EXPECT_EQ(features_left_out(FEATURE_ALL & ~FEATURE_GLASS), "glass");
}

TEST(TreeAuto, FollowsTheDeviceCostModel) {
    const Scene cornell = make_builtin_scene("cornell");
    TreeOptions o;
    o.kind = TreeKind::Auto;
    // 12 triangles: none on SIMT devices, the BVH on scalar ones (measured, kdtree.h).
    o.auto_model = kSimtCostModel;
    EXPECT_EQ(build_kdtree(cornell.triangles, o).kind, TreeKind::None);
    o.auto_model = kScalarCostModel;
    EXPECT_EQ(build_kdtree(cornell.triangles, o).kind, TreeKind::Bvh);
    // 20,000 triangles: the BVH everywhere.
    const Scene mesh = make_bumpy_sphere_scene(100);
    for (const TreeCostModel& m : {kSimtCostModel, kScalarCostModel}) {
        o.auto_model = m;
        const KdTree t = build_kdtree(mesh.triangles, o);
        EXPECT_EQ(t.kind, TreeKind::Bvh) << m.name;
        EXPECT_GT(t.stats.nodes, 100u) << m.name;
        EXPECT_NE(t.auto_choice.find("tree auto: bvh"), std::string::npos) << t.auto_choice;
    }
}

TEST(TreeAuto, ExpectedCostOfNoTreeIsEveryTriangle) {
    const Scene mesh = make_bumpy_sphere_scene(20);
    TreeOptions o;
    o.kind = TreeKind::None;
    const TreeCost none = expected_tree_cost(build_kdtree(mesh.triangles, o));
    EXPECT_DOUBLE_EQ(none.node_visits, 1.0);
    EXPECT_DOUBLE_EQ(none.triangle_tests, double(mesh.triangles.size()));
    o.kind = TreeKind::Sah;
    const TreeCost sah = expected_tree_cost(build_kdtree(mesh.triangles, o));
    EXPECT_LT(sah.triangle_tests, 0.05 * double(mesh.triangles.size()));
}

// ---------------------------------------------------------------- full vs specialized

struct Case {
    Scene scene;
    GpuScene gpu;
    RenderOptions options;
};

Case make_case(Scene scene, TreeKind kind) {
    validate_scene(scene);
    TreeOptions to;
    to.kind = kind;
    Case c{scene, pack_scene(scene, build_kdtree(scene.triangles, to)), {}};
    c.options.width = 24, c.options.height = 24;
    c.options.max_depth = scene.max_depth_hint > 0 ? uint32_t(scene.max_depth_hint) : 8u;
    return c;
}

// The full kernel (A) against a build for `features` (B, 0: the scene's own) on one backend,
// independent seeds.
Agreement full_vs_specialized(const std::string& backend, const Case& c, uint32_t features = 0) {
    BackendOptions full, special;
    if (backend == "opencl") full.device = special.device = test::test_opencl_device();
    full.features = FEATURE_ALL;
    special.features = features;
    auto a = open_device(backend, full);
    auto b = open_device(backend, special);
    BatchOptions bo;
    bo.batches = 32;
    bo.spp_per_batch = 8;
    bo.seed_base = 100;
    const BatchSet sa = render_batches(*a, c.gpu, c.scene.camera, c.options, bo);
    bo.seed_base = 7000;
    const BatchSet sb = render_batches(*b, c.gpu, c.scene.camera, c.options, bo);
    EXPECT_EQ(a->compiled_features(), FEATURE_ALL);
    EXPECT_EQ(b->compiled_features(), features ? features : c.gpu.features);
    const Agreement g = test_agreement(sa, sb, 0.01);
    std::printf("%s, %s (%s): %s\n", backend.c_str(), c.scene.name.c_str(),
                feature_names(b->compiled_features()).c_str(), g.verdict().c_str());
    return g;
}

class Specialized : public testing::TestWithParam<std::string> {};

TEST_P(Specialized, CornellWithTreeAgrees) {
    const Agreement g =
        full_vs_specialized(GetParam(), make_case(make_builtin_scene("cornell"), TreeKind::Sah));
    EXPECT_TRUE(g.agree) << g.verdict();
}

TEST_P(Specialized, CornellWithoutTreeAgrees) {
    const Agreement g =
        full_vs_specialized(GetParam(), make_case(make_builtin_scene("cornell"), TreeKind::None));
    EXPECT_TRUE(g.agree) << g.verdict();
}

TEST_P(Specialized, SpheresOnlyAgrees) {
    const Agreement g =
        full_vs_specialized(GetParam(), make_case(make_builtin_scene("spheres"), TreeKind::Sah));
    EXPECT_TRUE(g.agree) << g.verdict();
}

TEST_P(Specialized, FurnaceAgrees) {
    const Agreement g =
        full_vs_specialized(GetParam(), make_case(make_furnace_scene(0.8f, 1.f), TreeKind::Sah));
    EXPECT_TRUE(g.agree) << g.verdict();
}

// Negative control: a build without glass on the Cornell box (paths end at the glass
// sphere) must be rejected, and located.
TEST_P(Specialized, RejectsABuildWithoutGlass) {
    const Case c = make_case(make_builtin_scene("cornell"), TreeKind::Sah);
    const Agreement g = full_vs_specialized(GetParam(), c, c.gpu.features & ~FEATURE_GLASS);
    EXPECT_FALSE(g.agree) << g.verdict();
    EXPECT_GT(g.bh_discoveries, 0u);
}

INSTANTIATE_TEST_SUITE_P(Backends, Specialized,
#if MCPT_WITH_VULKAN
                         testing::Values("opencl", "vulkan"),
#else
                         testing::Values("opencl"),
#endif
                         [](const testing::TestParamInfo<std::string>& i) { return i.param; });

}  // namespace
}  // namespace mcpt
