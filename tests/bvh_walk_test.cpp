// A BVH walk paused every few node steps (MCPT_WALK_STEPS: common/gpu/integrator.h,
// step_slot_walk) changes when a lane shades, not what its rays hit or what its paths add:
// the materials scene (spheres, glass, metal, the area light's shadow rays), the textured one
// (cut-outs the walk passes through, in shadow rays too) and a deep mesh render the same image
// bit for bit walked whole and paused after every node (the mesh also
// every third), on both APIs. Control: a walk that loses its stack when it pauses (OpenCL: the
// define reaches its kernel only) gives another image. The count reaches the compiler, a
// count out of range is refused, which scenes walk, and render -v says whether one does.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>

#include "common/error.h"
#include "common/render/session.h"
#include "common/scene/builtin_scenes.h"
#include "common/scene/gltf_loader.h"
#include "test_util.h"

namespace mcpt {
namespace {

class BvhWalk : public ::testing::TestWithParam<std::string> {};

// `scene` through the BVH in reproducible mode, 16 samples; steps nullptr: the variable unset.
std::vector<float> render_walked(const std::string& api, const Scene& scene, const char* steps,
                                 const std::string& defines = "", std::string* settings = nullptr) {
    const test::ScopedEnv env("MCPT_WALK_STEPS", steps);
    BackendOptions o;
    o.extra_defines = defines;
    Session s(test::test_backend(api, o));
    s.set_scene(scene);
    s.settings().width = 48, s.settings().height = 40;
    s.settings().tree = "bvh";
    s.settings().reproducible = true;
    s.settings().seed = 3;
    s.render(1e6, 0, 16);
    if (settings) *settings = s.backend().build_settings();
    return s.image_rgba32f();
}

TEST_P(BvhWalk, PausedWalksGiveTheSameImage) {
    const Scene materials = make_builtin_scene("materials");
    EXPECT_EQ(render_walked(GetParam(), materials, "1"), render_walked(GetParam(), materials, "0"));
    const Scene textured = load_gltf(std::string(MCPT_TEST_DATA_DIR) + "/textured.glb");
    EXPECT_EQ(render_walked(GetParam(), textured, "1"), render_walked(GetParam(), textured, "0"));
    const Scene mesh = make_bumpy_sphere_scene(24);
    const std::vector<float> whole = render_walked(GetParam(), mesh, "0");
    EXPECT_EQ(render_walked(GetParam(), mesh, "1"), whole);
    EXPECT_EQ(render_walked(GetParam(), mesh, "3"), whole);
    // Negative control: a walk that forgets the subtrees it deferred. (The materials scene's
    // BVH is a root of leaves: nothing is deferred there.)
    if (GetParam() == "opencl") {
        EXPECT_NE(render_walked(GetParam(), mesh, "1", "-DMCPT_NEGATIVE_CONTROL_WALK"), whole);
    }
}

// The count reaches the compiler, with the one trace site the walk needs: OpenCL's build
// options, Vulkan's specialization constants.
TEST_P(BvhWalk, StepsReachTheCompiler) {
    const Scene scene = make_builtin_scene("materials");
    std::string walked, whole;
    render_walked(GetParam(), scene, "3", "", &walked);
    render_walked(GetParam(), scene, "0", "", &whole);
    const bool vk = GetParam() == "vulkan";
    for (const char* want : {vk ? "MCPT_WALK_STEPS=3" : "-DMCPT_WALK_STEPS=3u",
                             vk ? "MCPT_TRACE_SITES=1" : "-DMCPT_TRACE_SITES=1u"})
        EXPECT_NE(walked.find(want), std::string::npos) << walked;
    EXPECT_EQ(whole.find(vk ? "MCPT_WALK_STEPS=3" : "-DMCPT_WALK_STEPS"), std::string::npos)
        << whole;
}

TEST_P(BvhWalk, OutOfRangeIsRefused) {
    for (const char* bad : {"33", "-1", "4x", ""}) {
        try {
            render_walked(GetParam(), make_builtin_scene("materials"), bad);
            ADD_FAILURE() << "MCPT_WALK_STEPS='" << bad << "' accepted";
        } catch (const Error& e) {
            EXPECT_NE(std::string(e.what()).find("MCPT_WALK_STEPS must be 0 to 32, not '" +
                                                 std::string(bad) + "'"),
                      std::string::npos)
                << e.what();
        }
    }
}

// render -v says how the kernel traces: the walk where it is on, else every ray whole.
TEST_P(BvhWalk, RenderSaysWhetherItWalks) {
    const std::string out = (std::filesystem::temp_directory_path() /
                             ("mcpt_walk_says_" + GetParam() + std::to_string(getpid()) + ".exr"))
                                .string();
    const std::string args = "render cornell --tree bvh --width 16 --height 16 --spp 1 -v -o " +
                             out + " " + test::device_args(GetParam());
    const test::CliRun walked = test::run_mcpt(args, "MCPT_WALK_STEPS=3");
    ASSERT_EQ(walked.status, 0) << walked.output;
    EXPECT_NE(walked.output.find("trace sites: 1; BVH walked 3 node steps at a time"),
              std::string::npos)
        << walked.output;
    const test::CliRun whole = test::run_mcpt(args, "MCPT_WALK_STEPS=0");
    ASSERT_EQ(whole.status, 0) << whole.output;
    EXPECT_NE(whole.output.find("; every ray walked whole"), std::string::npos) << whole.output;
    std::filesystem::remove(out);
}

INSTANTIATE_TEST_SUITE_P(Backends, BvhWalk, ::testing::ValuesIn(test::test_apis()),
                         [](const auto& info) { return info.param; });

// Only scenes through our BVH walk; the driver's tracing never does.
TEST(BvhWalkChoice, OnlyTheBvh) {
    const test::ScopedEnv env("MCPT_WALK_STEPS", "4");
    DeviceInfo nv_vk;
    nv_vk.backend = "vulkan", nv_vk.name = "NVIDIA H100 80GB HBM3", nv_vk.platform = "NVIDIA";
    const uint32_t mesh = FEATURE_TRIANGLES | FEATURE_DIFFUSE | FEATURE_TRIANGLE_LIGHTS;
    EXPECT_EQ(walk_steps(nv_vk, mesh | FEATURE_BVH), 4u);
    EXPECT_EQ(trace_sites(nv_vk, mesh | FEATURE_BVH), 1u);
    EXPECT_EQ(walk_steps(nv_vk, mesh | FEATURE_KDTREE), 0u);
    EXPECT_EQ(walk_steps(nv_vk, mesh | FEATURE_BVH | FEATURE_ALPHA_MASK), 4u);
    EXPECT_EQ(walk_steps(nv_vk, mesh | FEATURE_BVH, true), 0u);
    EXPECT_EQ(trace_sites(nv_vk, mesh | FEATURE_BVH, true), 1u);
}

// The device's choice: NVIDIA's GPUs walk a BVH of depth 6 or more, 4 steps at a time (both
// APIs); shallower trees, other GPUs and the CPU devices walk every ray whole.
TEST(BvhWalkChoice, NvidiaGpusOnDeepTrees) {
    const test::ScopedEnv env("MCPT_WALK_STEPS", nullptr);
    DeviceInfo nv_vk, nv_cl, other_gpu, lavapipe;
    nv_vk.backend = "vulkan", nv_vk.type = "gpu", nv_vk.name = "NVIDIA H100 80GB HBM3";
    nv_cl.backend = "opencl", nv_cl.type = "gpu", nv_cl.name = "NVIDIA H100 80GB HBM3";
    nv_cl.platform = "NVIDIA CUDA";
    other_gpu.backend = "vulkan", other_gpu.type = "gpu", other_gpu.name = "Adreno (TM) 740";
    lavapipe.backend = "vulkan", lavapipe.type = "cpu", lavapipe.name = "llvmpipe (LLVM 19.1.7)";
    const uint32_t bvh =
        FEATURE_TRIANGLES | FEATURE_DIFFUSE | FEATURE_TRIANGLE_LIGHTS | FEATURE_BVH;
    for (const DeviceInfo* nv : {&nv_vk, &nv_cl}) {
        EXPECT_EQ(walk_steps(*nv, bvh, false, 6), 4u) << nv->backend;
        EXPECT_EQ(walk_steps(*nv, bvh, false, 9), 4u) << nv->backend;
        EXPECT_EQ(trace_sites(*nv, bvh, false, 9), 1u) << nv->backend;
        EXPECT_EQ(walk_steps(*nv, bvh, false, 5), 0u) << nv->backend;
        EXPECT_EQ(walk_steps(*nv, bvh, false, 0), 0u) << nv->backend;
        EXPECT_EQ(walk_steps(*nv, bvh, true, 9), 0u) << nv->backend;
    }
    EXPECT_EQ(trace_sites(nv_cl, bvh, false, 4), 2u);
    EXPECT_EQ(walk_steps(other_gpu, bvh, false, 9), 0u);
    EXPECT_EQ(walk_steps(lavapipe, bvh, false, 9), 0u);
    // The variable still decides where it is set.
    const test::ScopedEnv off("MCPT_WALK_STEPS", "0");
    EXPECT_EQ(walk_steps(nv_vk, bvh, false, 9), 0u);
}

// NVIDIA's OpenCL register cap by kernel: 128 walked, 96 for a BVH walked whole, 56 with
// textures and off the BVH; the variable overrides, and a bad value is refused.
TEST(NvidiaRegisterCap, ByKernel) {
    const test::ScopedEnv env("MCPT_NV_MAXRREGCOUNT", nullptr);
    const uint32_t mesh = FEATURE_TRIANGLES | FEATURE_DIFFUSE | FEATURE_TRIANGLE_LIGHTS;
    EXPECT_EQ(nvidia_register_cap(mesh | FEATURE_BVH, 4), 128u);
    EXPECT_EQ(nvidia_register_cap(mesh | FEATURE_BVH | FEATURE_TEXTURES, 4), 128u);
    EXPECT_EQ(nvidia_register_cap(mesh | FEATURE_BVH, 0), 96u);
    EXPECT_EQ(nvidia_register_cap(mesh | FEATURE_BVH | FEATURE_TEXTURES, 0), 56u);
    EXPECT_EQ(nvidia_register_cap(mesh | FEATURE_KDTREE, 0), 56u);
    EXPECT_EQ(nvidia_register_cap(mesh, 0), 56u);
    {
        const test::ScopedEnv none("MCPT_NV_MAXRREGCOUNT", "0");
        EXPECT_EQ(nvidia_register_cap(mesh | FEATURE_BVH, 4), 0u);
    }
    {
        const test::ScopedEnv some("MCPT_NV_MAXRREGCOUNT", "72");
        EXPECT_EQ(nvidia_register_cap(mesh | FEATURE_KDTREE, 0), 72u);
    }
    for (const char* bad : {"", "8", "256", "96x", "-1"}) {
        const test::ScopedEnv wrong("MCPT_NV_MAXRREGCOUNT", bad);
        EXPECT_THROW(nvidia_register_cap(mesh | FEATURE_BVH, 0), Error) << "'" << bad << "'";
    }
}

}  // namespace
}  // namespace mcpt
