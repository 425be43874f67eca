// Rays traced from one call or two (MCPT_TRACE_SITES: common/gpu/integrator.h, step_path)
// change where the kernel traverses, not what a path adds: the textured test scene (textures,
// cut-outs in shadow rays and camera rays, emission textures) renders the same image bit for
// bit either way, on both APIs (the CI's PoCL and lavapipe: on NVIDIA the two programs round
// differently), and the choice reaches the compiler. Which devices get one
// site (NVIDIA's Vulkan on scenes with textures) and a value out of range, refused.
#include <gtest/gtest.h>

#include <cstdlib>

#include "common/error.h"
#include "common/render/session.h"
#include "common/scene/gltf_loader.h"
#include "test_util.h"

namespace mcpt {
namespace {

class TraceSites : public ::testing::TestWithParam<std::string> {};

// The textured scene in reproducible mode, 16 samples; sites nullptr: the variable unset.
std::vector<float> render_textured(const std::string& api, const char* sites, uint32_t seed = 3,
                                   std::string* settings = nullptr) {
    const test::ScopedEnv env("MCPT_TRACE_SITES", sites);
    Session s(test::test_backend(api));
    s.set_scene(load_gltf(std::string(MCPT_TEST_DATA_DIR) + "/textured.glb"));
    s.settings().width = 48, s.settings().height = 40;
    s.settings().reproducible = true;
    s.settings().seed = seed;
    s.render(1e6, 0, 16);
    if (settings) *settings = s.backend().build_settings();
    return s.image_rgba32f();
}

TEST_P(TraceSites, OneOrTwoGiveTheSameImage) {
    const std::vector<float> two = render_textured(GetParam(), "2");
    EXPECT_EQ(render_textured(GetParam(), "1"), two);
    // Negative control: another seed is another image.
    EXPECT_NE(render_textured(GetParam(), "1", 4), two);
}

// The variable reaches the compiler: OpenCL's build options, Vulkan's specialization constants
// (without this, a backend that read it and never passed it on passed the test above).
TEST_P(TraceSites, ReachTheCompiler) {
    std::string one, two;
    render_textured(GetParam(), "1", 3, &one);
    render_textured(GetParam(), "2", 3, &two);
    const std::string want = GetParam() == "vulkan" ? "MCPT_TRACE_SITES=1" : "-DMCPT_TRACE_SITES=1u";
    EXPECT_NE(one.find(want), std::string::npos) << one;
    EXPECT_EQ(two.find(want), std::string::npos) << two;
}

TEST_P(TraceSites, OutOfRangeIsRefused) {
    try {
        render_textured(GetParam(), "3");
        ADD_FAILURE() << "MCPT_TRACE_SITES=3 accepted";
    } catch (const Error& e) {
        EXPECT_NE(std::string(e.what()).find("MCPT_TRACE_SITES must be 1 or 2, not '3'"),
                  std::string::npos)
            << e.what();
    }
}

INSTANTIATE_TEST_SUITE_P(Backends, TraceSites, ::testing::ValuesIn(test::test_apis()),
                         [](const auto& info) { return info.param; });

// One site where it was measured faster: NVIDIA's Vulkan driver, scenes with textures or a
// k-d tree, and its ray-tracing pipeline.
TEST(TraceSitesChoice, OneForNvidiaVulkanWithTexturesOrKdTree) {
    unsetenv("MCPT_TRACE_SITES");
    DeviceInfo nv_vk;
    nv_vk.backend = "vulkan", nv_vk.name = "NVIDIA H100 80GB HBM3", nv_vk.platform = "NVIDIA";
    DeviceInfo nv_cl = nv_vk;
    nv_cl.backend = "opencl", nv_cl.platform = "NVIDIA CUDA";
    DeviceInfo lavapipe;
    lavapipe.backend = "vulkan", lavapipe.name = "llvmpipe (LLVM 15.0.6, 256 bits)";
    lavapipe.platform = "llvmpipe";
    EXPECT_EQ(trace_sites(nv_vk, FEATURE_TEXTURES), 1u);
    EXPECT_EQ(trace_sites(nv_vk, FEATURE_ALL), 1u);
    const uint32_t mesh = FEATURE_TRIANGLES | FEATURE_DIFFUSE | FEATURE_TRIANGLE_LIGHTS;
    EXPECT_EQ(trace_sites(nv_vk, mesh | FEATURE_KDTREE), 1u);
    EXPECT_EQ(trace_sites(nv_vk, mesh | FEATURE_BVH), 2u);
    EXPECT_EQ(trace_sites(nv_vk, mesh), 2u);
    EXPECT_EQ(trace_sites(nv_cl, mesh | FEATURE_KDTREE), 2u);
    EXPECT_EQ(trace_sites(nv_cl, FEATURE_ALL), 2u);
    EXPECT_EQ(trace_sites(lavapipe, FEATURE_ALL), 2u);
    // The ray-tracing pipeline: one on NVIDIA's driver for every scene, two on lavapipe.
    EXPECT_EQ(trace_sites(nv_vk, mesh | FEATURE_BVH, true), 1u);
    EXPECT_EQ(trace_sites(nv_vk, mesh, true), 1u);
    EXPECT_EQ(trace_sites(lavapipe, mesh, true), 2u);
}

}  // namespace
}  // namespace mcpt
