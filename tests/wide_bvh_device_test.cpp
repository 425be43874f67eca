// The BVH on devices (PoCL and lavapipe in CI; on Vulkan through both ways of reading the
// scene: texel buffers, lavapipe's default, and storage buffers, what GPUs and phones take),
// beside the k-d tree: a same-seed render is the
// same image bit for bit through either tree on each API (a box with glass and mirrors, a
// mesh, a textured Blender scene with cut-outs) (the traversals find the same hits,
// ties included), and the BVH's images agree statistically across the APIs. Negative
// controls: a BVH whose leaf boxes miss half their triangles changes the same-seed image on
// both APIs, and fails the statistical comparison against the k-d tree's.
#include <gtest/gtest.h>

#include "common/accel/wide_bvh.h"
#include "common/analysis/compare.h"
#include "common/analysis/stats.h"
#include "common/render/device_registry.h"
#include "common/scene/builtin_scenes.h"
#include "common/scene/gltf_loader.h"
#include "test_util.h"

namespace mcpt {
namespace {

TreeOptions tree(TreeKind kind) {
    TreeOptions o;
    o.kind = kind;
    return o;
}

// Every leaf box cut to the lower half of its extent on x: the triangles beyond are never
// tested (a defect the image must show).
KdTree halved_leaf_boxes(KdTree bvh) {
    for (uint32_t n = 0; n < bvh_node_count(bvh); ++n) {
        gpu::BvhNode node = bvh_node(bvh, n);
        for (const BvhChild& c : bvh_children(node)) {
            if (c.internal) continue;
            const uint32_t lo = bvh_plane(node, 0, false, c.slot), hi = bvh_plane(node, 0, true, c.slot);
            set_bvh_plane(node, 0, true, c.slot, (lo + hi) / 2);
        }
        set_bvh_node(bvh, n, node);
    }
    return bvh;
}

struct Scenes {
    std::string name;
    Scene scene;
};
std::vector<Scenes> scenes() {
    std::vector<Scenes> s;
    s.push_back({"cornell", make_builtin_scene("cornell")});
    s.push_back({"bumpy sphere", make_bumpy_sphere_scene(40)});
    s.push_back({"textured", load_gltf(std::string(MCPT_TEST_DATA_DIR) + "/textured.glb")});
    for (Scenes& c : s) validate_scene(c.scene);
    return s;
}

RenderOptions same_seed_options() {
    RenderOptions o;
    o.width = o.height = 32;
    o.spp = 4;
    o.seed = 11;
    return o;
}

// The devices the BVH runs on: each API, and Vulkan once more reading the scene through
// storage buffers (BVH_QUAD and LEAF_INDEX from tree_words) instead of texels.
struct TestDevice {
    std::string name;
    std::unique_ptr<Backend> backend;
};
std::vector<TestDevice> test_devices() {
    std::vector<TestDevice> d;
    for (const std::string& api : test::test_apis()) {
        d.push_back({api, test::test_backend(api)});
        if (api != "vulkan") continue;
        BackendOptions storage;
        storage.scene_reads = "storage";
        d.push_back({"vulkan (storage buffers)", test::test_backend(api, storage)});
        EXPECT_EQ(d.back().backend->layout().find("texel buffers"), std::string::npos)
            << d.back().backend->layout();
    }
    return d;
}

bool same_sums(const RenderResult& a, const RenderResult& b) {
    return a.sum == b.sum && a.sum_sq == b.sum_sq && a.nonfinite == b.nonfinite;
}

TEST(WideBvhDevices, SameSeedImageIsTheKdTreesOnEachApi) {
    for (const TestDevice& t : test_devices()) {
        const std::string& api = t.name;
        Backend* device = t.backend.get();
        for (const Scenes& c : scenes()) {
            const RenderOptions o = same_seed_options();
            const GpuScene kd = pack_scene(c.scene, build_kdtree(c.scene.triangles, tree(TreeKind::Sah)));
            const KdTree bvh_tree = build_kdtree(c.scene.triangles, tree(TreeKind::Bvh));
            const GpuScene bvh = pack_scene(c.scene, bvh_tree);
            ASSERT_NE(bvh.features & FEATURE_BVH, 0u);
            ASSERT_EQ(bvh.features & FEATURE_KDTREE, 0u);
            const RenderResult a = render(*device, kd, c.scene.camera, o);
            const RenderResult b = render(*device, bvh, c.scene.camera, o);
            EXPECT_TRUE(same_sums(a, b)) << api << ", " << c.name;
            EXPECT_EQ(a.rays, b.rays) << api << ", " << c.name;
            // Negative control: leaf boxes halved.
            const GpuScene broken = pack_scene(c.scene, halved_leaf_boxes(bvh_tree));
            const SameSeedDiff d = same_seed_diff(a, render(*device, broken, c.scene.camera, o));
            EXPECT_GT(d.fraction_diverged(), 0.05) << api << ", " << c.name << ": " << d.diverged
                                                   << " of " << d.pixels << " pixels changed";
        }
    }
}

// OpenCL's BVH against Vulkan's, and each against the other API's k-d tree: AGREE; the broken
// BVH on Vulkan against the k-d tree on OpenCL: rejected.
TEST(WideBvhDevices, AgreesAcrossApisAndTrees) {
    Scene scene = make_bumpy_sphere_scene(60);
    validate_scene(scene);
    const KdTree bvh_tree = build_kdtree(scene.triangles, tree(TreeKind::Bvh));
    const GpuScene bvh = pack_scene(scene, bvh_tree);
    const GpuScene kd = pack_scene(scene, build_kdtree(scene.triangles, tree(TreeKind::Sah)));
    const GpuScene broken = pack_scene(scene, halved_leaf_boxes(bvh_tree));
    auto cl = test::test_opencl_backend();
    auto vk = test::test_backend("vulkan");
    RenderOptions o;
    o.width = o.height = 32;
    BatchOptions bo;
    bo.batches = 32;
    bo.spp_per_batch = 8;
    const auto batches = [&](Backend& d, const GpuScene& g, uint32_t seed) {
        bo.seed_base = seed;
        return render_batches(d, g, scene.camera, o, bo);
    };
    BackendOptions storage;
    storage.scene_reads = "storage";
    auto vk_storage = test::test_backend("vulkan", storage);
    const BatchSet cl_bvh = batches(*cl, bvh, 100), vk_bvh = batches(*vk, bvh, 5000);
    const BatchSet cl_kd = batches(*cl, kd, 9000), vk_kd = batches(*vk, kd, 13000);
    const BatchSet vks_bvh = batches(*vk_storage, bvh, 21000);
    for (const auto& [what, a, b] :
         {std::tuple{"OpenCL BVH / Vulkan BVH", &cl_bvh, &vk_bvh},
          std::tuple{"OpenCL BVH / Vulkan k-d", &cl_bvh, &vk_kd},
          std::tuple{"OpenCL k-d / Vulkan BVH", &cl_kd, &vk_bvh},
          std::tuple{"OpenCL k-d / Vulkan BVH from storage buffers", &cl_kd, &vks_bvh}}) {
        const Agreement g = test_agreement(*a, *b, 0.01);
        EXPECT_TRUE(g.agree) << what << ": " << g.verdict();
    }
    const Agreement bad = test_agreement(cl_kd, batches(*vk, broken, 17000), 0.01);
    EXPECT_FALSE(bad.agree) << "a BVH missing half its leaves' triangles passed: " << bad.verdict();
    const Agreement bad_storage = test_agreement(cl_kd, batches(*vk_storage, broken, 25000), 0.01);
    EXPECT_FALSE(bad_storage.agree) << "storage buffers: a BVH missing half its leaves' "
                                       "triangles passed: "
                                    << bad_storage.verdict();
}

}  // namespace
}  // namespace mcpt
