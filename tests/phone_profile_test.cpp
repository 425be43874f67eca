// The phone limits profile (Vulkan 1.1 required minimums): the backend works within it, says
// so, refuses what does not fit, and renders what the device profile renders: statistically
// on a few scenes, and with the same seed value for value on every kind of scene the
// statistical suites use (which stands for rerunning them all under the profile).
#include <gtest/gtest.h>

#include "common/analysis/compare.h"
#include "common/error.h"
#include "common/render/device_registry.h"
#include "common/scene/gltf_loader.h"
#include "light_cases.h"
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

// Same seed, every kind of scene the statistical suites render: the phone profile changes how
// the scene is read (storage buffers past 65,536 texels), how the image is accumulated
// (windows), how dispatches are cut and the workgroup, never the arithmetic, so its image is
// the device profile's up to the order of float sums. This is what stands for running every
// Vulkan suite once more under the profile: the suites whose code paths the profile changes
// still run under it (tests/CMakeLists.txt, ".phone"). Control: a light 0.1 % brighter on the
// phone side must part the images.
Scene phone_case(const std::string& name) {
    const std::string data = MCPT_TEST_DATA_DIR;
    if (name == "bumpy_bvh") return make_bumpy_sphere_scene(60);
    if (name == "deep_furnace") return make_furnace_scene(0.99f, 1.f);
    if (name == "textured") return load_gltf(data + "/textured.glb");
    if (name == "lamps") return load_gltf(data + "/lamps.gltf");
    if (name == "emissive_triangle") return load_gltf(data + "/emissive_triangle.gltf");
    if (name == "map_and_sun") {
        Scene s = test::plane_scene(0.7f, 2.f, 1.f);
        s.environment = test::map_with_sun(64, 32, 0.3f, 20, 6, 3000.f);
        return s;
    }
    if (name == "beyond_phone_texels") {  // 75,000 texels of triangles: storage reads on phones
        Scene s = make_builtin_scene("cornell");
        for (int i = 0; i < 30000; ++i) {
            const glm::vec3 o(float(i % 200), -1000.f, float(i / 200));
            s.triangles.push_back({o, o + glm::vec3(0.5f, 0.f, 0.f), o + glm::vec3(0.f, 0.f, 0.5f), 0});
        }
        return s;
    }
    return make_builtin_scene(name);  // cornell, materials, spheres
}

struct PhoneSameSeed {
    size_t apart = 0, values = 0;
    std::string desktop_layout, phone_layout;
};

PhoneSameSeed phone_same_seed(const std::string& name, float phone_light_scale = 1.f) {
    Scene scene = phone_case(name);
    validate_scene(scene);
    TreeOptions to;
    to.kind = name == "bumpy_bvh" || name == "textured" || name == "materials" ? TreeKind::Bvh
                                                                               : TreeKind::Sah;
    const GpuScene g = pack_scene(scene, build_kdtree(scene.triangles, to));
    RenderOptions o;
    o.width = o.height = 24;
    o.spp = 4;
    o.seed = 11;
    if (scene.max_depth_hint > 0) o.max_depth = uint32_t(scene.max_depth_hint);
    auto desktop = open_device("vulkan,limits=device");
    auto phone = open_device("vulkan,limits=phone");
    const RenderResult a = render(*desktop, g, scene.camera, o);
    o.light_scale = phone_light_scale;
    const RenderResult b = render(*phone, g, scene.camera, o);
    PhoneSameSeed r;
    r.desktop_layout = desktop->layout(), r.phone_layout = phone->layout();
    const std::vector<float> x = a.mean_image(), y = b.mean_image();
    EXPECT_EQ(x.size(), y.size());
    EXPECT_EQ(a.nonfinite_total, b.nonfinite_total);
    r.values = std::min(x.size(), y.size());
    for (size_t i = 0; i < r.values; ++i)
        r.apart += std::abs(x[i] - y[i]) > 1e-5f * std::max(1e-3f, std::abs(x[i]));
    std::printf("%s: %zu of %zu values apart (phone light x%g)\n", name.c_str(), r.apart, r.values,
                double(phone_light_scale));
    return r;
}

class PhoneProfileScenes : public testing::TestWithParam<std::string> {};

TEST_P(PhoneProfileScenes, SameSeedImageIsTheDeviceProfiles) {
    const PhoneSameSeed r = phone_same_seed(GetParam());
    EXPECT_EQ(r.apart, 0u) << r.apart << " of " << r.values << " values";
    if (GetParam() == "beyond_phone_texels") {
        EXPECT_NE(r.desktop_layout.find("texel buffers"), std::string::npos) << r.desktop_layout;
        EXPECT_EQ(r.phone_layout.find("texel buffers"), std::string::npos) << r.phone_layout;
    }
}

INSTANTIATE_TEST_SUITE_P(Scenes, PhoneProfileScenes,
                         testing::Values("cornell", "materials", "spheres", "bumpy_bvh",
                                         "deep_furnace", "textured", "lamps", "emissive_triangle",
                                         "map_and_sun", "beyond_phone_texels"),
                         [](const testing::TestParamInfo<std::string>& i) { return i.param; });

TEST(PhoneProfile, SameSeedControlBrighterLightParts) {
    const PhoneSameSeed r = phone_same_seed("cornell", 1.001f);
    EXPECT_GT(r.apart, r.values / 2) << r.apart << " of " << r.values << " values";
}

}  // namespace
}  // namespace mcpt
