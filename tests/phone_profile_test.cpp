// The phone limits profile (Vulkan 1.1 required minimums): the backend works within it, says
// so, refuses what does not fit, and renders what the device profile renders.
#include <gtest/gtest.h>

#include "common/analysis/compare.h"
#include "common/error.h"
#include "common/render/device_registry.h"
#include "test_scenes.h"
#include "test_util.h"
#include "vulkan/vk_backend.h"

namespace mcpt {
namespace {

std::string error_of(const std::string& spec) {
    try {
        open_device(spec);
    } catch (const Error& e) {
        return e.what();
    }
    return "";
}

TEST(PhoneProfile, ClampsEveryLimitTheBackendReads) {
    auto b = open_device("vulkan,limits=phone");
    const DeviceInfo& d = b->device();
    EXPECT_NE(b->description().find("phone limits"), std::string::npos);
    EXPECT_EQ(b->layout().rfind("4 storage buffers per stage (device allows 4)", 0), 0u)
        << b->layout();
    EXPECT_LE(d.memory.max_buffer_bytes, 128ull << 20);
    EXPECT_LE(d.memory.max_allocation_bytes, 1ull << 30);
    EXPECT_LE(dynamic_cast<VulkanBackend&>(*b).local_size(), 128u);
    bool listed = false;
    for (const auto& [name, value] : d.limits) {
        if (name == "maxComputeWorkGroupInvocations") {
            EXPECT_EQ(value, "128");
        }
        if (name == "maxPerStageDescriptorStorageBuffers") {
            EXPECT_EQ(value, "4");
        }
        if (name == "limits profile") listed = value.rfind("phone", 0) == 0;
    }
    EXPECT_TRUE(listed);
}

TEST(PhoneProfile, BadProfilesAndOptionsAreRefused) {
    EXPECT_NE(error_of("opencl,limits=phone").find("Vulkan only"), std::string::npos);
    EXPECT_NE(error_of("vulkan,limits=tablet").find("unknown limits profile 'tablet'"),
              std::string::npos);
    EXPECT_NE(error_of("vulkan,speed=fast").find("unknown device option 'speed=fast'"),
              std::string::npos);
}

TEST(PhoneProfile, SceneBeyondTheProfileNamesBufferSizeAndLimit) {
    auto b = open_device("vulkan,limits=phone");
    Scene scene = make_builtin_scene("cornell");
    GpuScene g = pack_scene(scene, build_kdtree(scene.triangles, TreeOptions{}));
    // An image whose sums exceed 128 MiB (256 MiB) loads, accumulating through a window.
    b->load(g, 4096, 2048, false);
    EXPECT_NE(b->layout().find("accumulation in windows of"), std::string::npos) << b->layout();
    // A scene array over 128 MiB is refused with its name, size and the limit.
    g.triangles.resize((129u << 20) / sizeof(gpu::GpuTriangle) + 1);
    try {
        b->load(g, 64, 64, false);
        FAIL() << "a triangle buffer over 128 MiB was accepted";
    } catch (const Error& e) {
        EXPECT_NE(std::string(e.what()).find("triangles need 129 MiB, "
                                             "maxStorageBufferRange is 128 MiB"),
                  std::string::npos)
            << e.what();
    }
}

// Desktop limits (A) against the phone profile (B) on one device, independent seeds.
Agreement desktop_vs_phone(Scene scene, float phone_light_scale = 1.f,
                           TreeKind tree = TreeKind::Sah) {
    validate_scene(scene);
    TreeOptions to;
    to.kind = tree;
    const GpuScene g = pack_scene(scene, build_kdtree(scene.triangles, to));
    RenderOptions o;
    o.width = 32, o.height = 32, o.max_depth = 8;
    BatchOptions bo;
    bo.batches = 32, bo.spp_per_batch = 8, bo.seed_base = 100;
    auto a = open_device("vulkan,limits=device");
    auto b = open_device("vulkan,limits=phone");
    const BatchSet sa = render_batches(*a, g, scene.camera, o, bo);
    o.light_scale = phone_light_scale;
    bo.seed_base = 5000;
    const BatchSet sb = render_batches(*b, g, scene.camera, o, bo);
    const Agreement r = test_agreement(sa, sb, 0.01);
    std::printf("%s\n", r.verdict().c_str());
    return r;
}

TEST(PhoneProfile, AgreesWithDesktopOnCornell) {
    const Agreement g = desktop_vs_phone(make_builtin_scene("cornell"));
    EXPECT_TRUE(g.agree) << g.verdict();
}

TEST(PhoneProfile, AgreesWithDesktopOnADeepMeshTree) {
    const Agreement g = desktop_vs_phone(make_bumpy_sphere_scene(100));
    EXPECT_TRUE(g.agree) << g.verdict();
}

TEST(PhoneProfile, AgreesWithDesktopOnADeepMeshBvh) {
    const Agreement g = desktop_vs_phone(make_bumpy_sphere_scene(100), 1.f, TreeKind::Bvh);
    EXPECT_TRUE(g.agree) << g.verdict();
}

TEST(PhoneProfile, NegativeControlBrighterLightIsRejected) {
    const Agreement g = desktop_vs_phone(make_builtin_scene("cornell"), 1.02f);
    EXPECT_FALSE(g.agree) << g.verdict();
}

}  // namespace
}  // namespace mcpt
