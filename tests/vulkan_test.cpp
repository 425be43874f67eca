// The Vulkan port against the validation layer, the furnace, its device limits and the
// OpenCL reference. Every test skips when there is no Vulkan device (lavapipe in CI).
#include <gtest/gtest.h>

#if MCPT_WITH_VULKAN

#include <cstdlib>
#include <cstring>
#include <iostream>
#include <optional>

#include "common/error.h"
#include "common/render/gpu_scene.h"
#include "common/scene/builtin_scenes.h"
#include "test_util.h"
#include "vulkan/vk_backend.h"

namespace mcpt {
namespace {

constexpr double kZLimit = 4.5;  // as in furnace_test.cpp

using test::ScopedEnv;

bool have_vulkan() {
    return !list_vulkan_devices().empty();
}

#define SKIP_WITHOUT_VULKAN()                                                 \
    do {                                                                      \
        if (!have_vulkan()) {                                                 \
            GTEST_SKIP() << "no Vulkan device (install mesa-vulkan-drivers)"; \
        }                                                                     \
    } while (0)

// The Vulkan device the tests run on: $MCPT_TEST_VULKAN_DEVICE (index or name), else the best.
std::unique_ptr<VulkanBackend> open_vulkan() {
    BackendOptions o;
    if (const char* e = std::getenv("MCPT_TEST_VULKAN_DEVICE")) o.device = e;
    std::unique_ptr<Backend> b = make_vulkan_backend(o);
    auto* vk = dynamic_cast<VulkanBackend*>(b.get());
    if (!vk) return nullptr;
    b.release();
    return std::unique_ptr<VulkanBackend>(vk);
}

struct Packed {
    Scene scene;
    GpuScene gpu;
};

Packed pack(Scene scene) {
    validate_scene(scene);
    GpuScene g = pack_scene(scene, build_kdtree(scene.triangles, TreeOptions{}));
    return {std::move(scene), std::move(g)};
}

RenderResult render_on(Backend& backend, const Packed& p, int size, uint64_t spp, uint32_t seed,
                       float light_scale = 1.f) {
    RenderOptions o;
    o.width = o.height = size;
    o.spp = spp;
    o.seed = seed;
    o.light_scale = light_scale;
    if (p.scene.max_depth_hint > 0) o.max_depth = uint32_t(p.scene.max_depth_hint);
    return render(backend, p.gpu, p.scene.camera, o);
}

// (a) Both built-in scenes under VK_LAYER_KHRONOS_validation: no message, no NaN/Inf.
TEST(VulkanValidation, BuiltinScenesRenderWithoutMessages) {
    SKIP_WITHOUT_VULKAN();
    ScopedEnv validation("MCPT_VULKAN_VALIDATION", "1");
    std::unique_ptr<VulkanBackend> vk;
    try {
        vk = open_vulkan();
    } catch (const Error& e) {
        if (std::strstr(e.what(), "not installed")) GTEST_SKIP() << e.what();
        throw;
    }
    ASSERT_TRUE(vk);
    for (const std::string name : {"cornell", "furnace"}) {
        const Packed p = pack(make_builtin_scene(name));
        const RenderResult r = render_on(*vk, p, 32, 4, 1);
        EXPECT_EQ(r.nonfinite_total, 0u) << name;
        EXPECT_GT(r.rays, 0) << name;
        EXPECT_GT(r.mean_radiance(), 0) << name;
        EXPECT_EQ(vk->validation_messages(), 0u) << name << ": see the messages on stderr";
    }
    if (vk->has_gpu_timer()) {
        EXPECT_GT(vk->gpu_seconds(), 0);
    }
    EXPECT_GT(vk->compile_seconds(), 0);
}

// (b) The white furnace: Le / (1 - rho) = 2 within its confidence interval, sharp enough that a
// 2% brighter light is rejected.
TEST(VulkanFurnace, MatchesExactRadianceAndRejectsBrighterLight) {
    SKIP_WITHOUT_VULKAN();
    auto vk = open_vulkan();
    const Packed p = pack(make_furnace_scene(0.5f, 1.0f));
    const double exact = 1.0 / (1.0 - 0.5);
    const RenderResult r = render_on(*vk, p, 32, 256, 7);
    const test::MeanEstimate e = test::pooled_mean(r);
    RecordProperty("relative_std_error", std::to_string(e.std_error / exact));
    EXPECT_EQ(r.nonfinite_total, 0u);
    EXPECT_LT(std::abs(e.z(exact)), kZLimit)
        << "mean " << e.mean << " exact " << exact << " std error " << e.std_error;
    EXPECT_LT(e.std_error / exact, 0.02 / (2 * kZLimit));
    const test::MeanEstimate bright = test::pooled_mean(render_on(*vk, p, 32, 256, 7, 1.02f));
    EXPECT_GT(bright.z(exact), kZLimit) << "a 2% brighter light went unnoticed";
}

// (c) A buffer over maxStorageBufferRange is refused with a clear message, before allocation;
// the limit is lowered through MCPT_VULKAN_MAX_BUFFER_BYTES instead of allocating 128 MiB.
TEST(VulkanLimits, RefusesBufferOverMaxStorageBufferRange) {
    SKIP_WITHOUT_VULKAN();
    auto vk = open_vulkan();
    const Packed p = pack(make_builtin_scene("cornell"));
    {
        ScopedEnv limit("MCPT_VULKAN_MAX_BUFFER_BYTES", "256");
        try {
            vk->load(p.gpu, 32, 32, false);
            FAIL() << "a 256-byte maxStorageBufferRange was not enforced";
        } catch (const Error& e) {
            const std::string m = e.what();
            EXPECT_NE(m.find("scene too large for vulkan: "), std::string::npos) << m;
            EXPECT_NE(m.find("maxStorageBufferRange is 256 B"), std::string::npos) << m;
        }
    }
    // An image whose sums exceed any device's range (8 GiB > 4 GiB) accumulates through a
    // window within it.
    vk->load(p.gpu, 16384, 16384, false);
    EXPECT_NE(vk->layout().find("accumulation in windows of"), std::string::npos) << vk->layout();
    // The same backend still works within the limits.
    const RenderResult r = render_on(*vk, p, 16, 1, 0);
    EXPECT_GT(r.mean_radiance(), 0);
}

// A dispatch split into workgroup-count-limited pixel ranges gives the same sums.
TEST(VulkanDispatch, SplitDispatchMatchesSingleDispatch) {
    SKIP_WITHOUT_VULKAN();
    const Packed p = pack(make_builtin_scene("cornell"));
    const int size = 32;
    auto run = [&](bool split) {
        std::optional<ScopedEnv> limit;
        if (split) limit.emplace("MCPT_VULKAN_MAX_GROUP_COUNT", "1");
        auto vk = open_vulkan();
        vk->load(p.gpu, size, size, false);
        gpu::GpuParams params = p.gpu.params;
        set_camera(params, p.scene.camera, size, size);
        params.max_depth = 8, params.rr_depth = 3, params.seed = 5, params.light_scale = 1.f;
        params.pixel_offset = 0, params.pixel_count = size * size;
        params.sample_offset = 0, params.samples_per_dispatch = 2, params.accumulate = 0;
        params.state_base = 0, params.state_slots = accum_layout(size * size, 0).slots;
        params.bounce_budget = 4;  // several dispatches per round
        params.round_start = 1;
        while (vk->dispatch(params) > 0) params.round_start = 0;
        EXPECT_GT(uint32_t(size * size), vk->local_size()) << "no split to test";
        std::vector<float> accum;
        vk->read_accum(accum, 0);
        return accum;
    };
    const std::vector<float> single = run(false), split = run(true);
    ASSERT_EQ(single.size(), split.size());
    // The dispatch-base pipeline is a separate compile: a GPU may round differently (NVIDIA
    // does), so a value may move by rounding and a rare path may diverge; a pixel missed or
    // computed twice would differ by far more, and in many values.
    size_t differ = 0;
    for (size_t i = 0; i < single.size(); ++i)
        differ += std::abs(single[i] - split[i]) > 1e-3f * std::max(1.f, std::abs(single[i]));
    EXPECT_LE(differ, single.size() / 200) << differ << " of " << single.size() << " values";
}

// The tree, triangles and shading data read through texel buffers (CPU devices' default) or
// storage buffers: the same words, so the same sums, value for value.
TEST(VulkanSceneReads, TexelAndStorageReadsGiveTheSameImage) {
    SKIP_WITHOUT_VULKAN();
    const Packed p = pack(make_builtin_scene("cornell"));  // tree, spheres, lights
    ASSERT_GT(p.gpu.params.num_nodes, 1u);
    auto run = [&](const char* reads, std::string& layout) {
        BackendOptions o;
        if (const char* e = std::getenv("MCPT_TEST_VULKAN_DEVICE")) o.device = e;
        o.scene_reads = reads;
        std::unique_ptr<Backend> vk = make_vulkan_backend(o);
        const RenderResult r = render_on(*vk, p, 24, 8, 11);
        layout = vk->layout();
        return r.mean_image();
    };
    std::string texel_layout, storage_layout;
    const std::vector<float> texel = run("texel", texel_layout);
    const std::vector<float> storage = run("storage", storage_layout);
    EXPECT_NE(texel_layout.find("texel buffers"), std::string::npos) << texel_layout;
    EXPECT_EQ(storage_layout.find("texel buffers"), std::string::npos) << storage_layout;
    // Unasked, CPU devices read texels and GPUs storage buffers.
    if (!std::getenv("MCPT_VULKAN_SCENE_READS")) {
        auto vk = open_vulkan();
        render_on(*vk, p, 8, 1, 1);
        const bool texels = vk->layout().find("texel buffers") != std::string::npos;
        EXPECT_EQ(texels, vk->device().type == "cpu") << vk->device().type << ": " << vk->layout();
    }
    ASSERT_EQ(texel.size(), storage.size());
    // Two pipelines: a GPU compiler may round differently, as in
    // SplitDispatchMatchesSingleDispatch.
    size_t differ = 0;
    for (size_t i = 0; i < texel.size(); ++i)
        differ += std::abs(texel[i] - storage[i]) > 1e-3f * std::max(1.f, std::abs(texel[i]));
    EXPECT_LE(differ, texel.size() / 200) << differ << " of " << texel.size() << " values";
    RecordProperty("values_differing", std::to_string(differ));

    // A scene over the phone's 65,536 texels (triangles far below the box) is read through
    // the storage buffers, and a name other than texel or storage is refused.
    Scene big = make_builtin_scene("cornell");
    for (int i = 0; i < 30000; ++i) {  // 75,000 texels of 16 bytes
        const glm::vec3 o(float(i % 200), -1000.f, float(i / 200));
        big.triangles.push_back(
            {o, o + glm::vec3(0.5f, 0.f, 0.f), o + glm::vec3(0.f, 0.f, 0.5f), 0});
    }
    const Packed pb = pack(std::move(big));
    BackendOptions o;
    if (const char* e = std::getenv("MCPT_TEST_VULKAN_DEVICE")) o.device = e;
    o.scene_reads = "texel";
    o.limits = "phone";
    std::unique_ptr<Backend> phone = make_vulkan_backend(o);
    const RenderResult r = render_on(*phone, pb, 8, 2, 1);
    EXPECT_EQ(phone->layout().find("texel buffers"), std::string::npos) << phone->layout();
    EXPECT_EQ(r.nonfinite_total, 0u);
    o.limits = "";
    o.scene_reads = "gather";
    std::unique_ptr<Backend> bad = make_vulkan_backend(o);
    EXPECT_THROW(render_on(*bad, p, 8, 1, 1), Error);
}

// (d) Same seed, same random stream: Vulkan and OpenCL agree pixel by pixel up to float
// rounding (which can send a few paths elsewhere).
TEST(VulkanVsOpenCl, SameSeedImagesAgree) {
    SKIP_WITHOUT_VULKAN();
    if (list_opencl_devices().empty()) GTEST_SKIP() << "no OpenCL device";
    const Packed p = pack(make_builtin_scene("cornell"));
    auto cl = test::test_opencl_backend();
    auto vk = open_vulkan();
    const std::vector<float> a = render_on(*cl, p, 16, 4, 3).mean_image();
    const std::vector<float> b = render_on(*vk, p, 16, 4, 3).mean_image();
    ASSERT_EQ(a.size(), b.size());
    size_t diverged = 0;
    const size_t pixels = a.size() / 3;
    for (size_t i = 0; i < pixels; ++i) {
        bool agree = true;
        for (int c = 0; c < 3; ++c) {
            const float x = a[3 * i + c], y = b[3 * i + c];
            agree = agree && std::abs(x - y) <= 1e-3f * std::max(std::abs(x), std::abs(y));
        }
        diverged += !agree;
    }
    const double fraction = double(diverged) / double(pixels);
    RecordProperty("fraction_diverged", std::to_string(fraction));
    std::cout << "vulkan vs opencl, cornell 16x16 4 spp seed 3: " << diverged << " of " << pixels
              << " pixels diverged (" << 100.0 * fraction << "%)\n";
    EXPECT_LE(fraction, 0.05);
}

// Device list and options the port cannot honour.
// Paths of about a thousand bounces (furnace, albedo 0.999) exceed llvmpipe's 65,535 loop
// iterations per invocation in one dispatch; carried across dispatches, none is cut.
TEST(VulkanLoopLimit, ThousandBouncePathsAreNeverCut) {
    SKIP_WITHOUT_VULKAN();
    auto vk = open_vulkan();
    ASSERT_TRUE(vk);
    const Packed p = pack(make_furnace_scene(0.999f, 1.f));
    RenderOptions o;
    o.width = o.height = 4;
    o.spp = 8;
    o.seed = 3;
    o.max_depth = 100000;
    const RenderResult r = render(*vk, p.gpu, p.scene.camera, o);
    for (float v : r.mean_image()) EXPECT_TRUE(std::isfinite(v));
    // Paths of ~1000 bounces continue across dispatches: none is cut, on llvmpipe either
    // (whose loop limit cut them before paths were carried across dispatches).
    EXPECT_EQ(r.nonfinite_total, 0u);
    if (vk->device().type == "cpu") {
        EXPECT_LE(vk->max_bounces_per_dispatch(), 64u);
    }
}

// Forty backends, one after the other, in one process: NVIDIA's driver refuses instances
// after about thirty, so backends share the process's instance (vk::shared_instance).
TEST(VulkanInstances, FortyBackendsInOneProcess) {
    SKIP_WITHOUT_VULKAN();
    const Packed p = pack(make_builtin_scene("cornell"));
    for (int i = 0; i < 40; ++i) {
        auto vk = open_vulkan();
        ASSERT_TRUE(vk) << "backend " << i;
        const RenderResult r = render_on(*vk, p, 4, 1, uint32_t(i));
        ASSERT_EQ(r.spp, 1u) << "backend " << i;
    }
}

TEST(VulkanDevices, ListedWithLimitsAndOpenClOnlyOptionsRefused) {
    SKIP_WITHOUT_VULKAN();
    for (const DeviceInfo& d : list_vulkan_devices()) {
        EXPECT_EQ(d.backend, "vulkan");
        bool has_range = false;
        for (const auto& [k, v] : d.limits) has_range = has_range || k == "maxStorageBufferRange";
        EXPECT_TRUE(has_range) << d.name;
    }
    BackendOptions o;
    o.fast_math = true;
    EXPECT_THROW(make_vulkan_backend(o), Error);
    o.fast_math = false;
    o.extra_defines = "-DMCPT_NEGATIVE_CONTROL_RR";
    EXPECT_THROW(make_vulkan_backend(o), Error);
    o.extra_defines.clear();
    o.device = "no such device";
    EXPECT_THROW(make_vulkan_backend(o), Error);
}

// $MCPT_VULKAN_STATISTICS=1: the layout line (render -v) carries the driver's statistics of the
// compute pipeline, or why there are none (lavapipe 22 lacks the extension); unset: no word of
// them; any other value: a clear error before a device is made.
TEST(VulkanStatistics, LayoutNamesTheDriversStatisticsOnlyWhenAsked) {
    SKIP_WITHOUT_VULKAN();
    const Packed p = pack(make_builtin_scene("cornell"));
    {
        const ScopedEnv off("MCPT_VULKAN_STATISTICS", nullptr);
        auto vk = open_vulkan();
        render_on(*vk, p, 4, 1, 1u);
        EXPECT_EQ(vk->layout().find("statistics"), std::string::npos) << vk->layout();
    }
    {
        const ScopedEnv on("MCPT_VULKAN_STATISTICS", "1");
        auto vk = open_vulkan();
        const RenderResult r = render_on(*vk, p, 4, 1, 1u);
        EXPECT_EQ(r.spp, 1u);
        const std::string layout = vk->layout();
        const std::string some = "; the driver's statistics: ";
        const size_t at = layout.find(some);
        EXPECT_TRUE(at != std::string::npos ||
                    layout.find("; no driver statistics (") != std::string::npos)
            << layout;
        if (at != std::string::npos) {
            EXPECT_GT(layout.size(), at + some.size()) << layout;
        }
        std::cout << "[ info ] " << layout << "\n";
    }
    {
        const ScopedEnv bad("MCPT_VULKAN_STATISTICS", "yes");
        try {
            auto vk = open_vulkan();
            render_on(*vk, p, 4, 1, 1u);
            ADD_FAILURE() << "MCPT_VULKAN_STATISTICS=yes was accepted";
        } catch (const Error& e) {
            EXPECT_NE(std::string(e.what()).find("MCPT_VULKAN_STATISTICS must be 0 or 1"),
                      std::string::npos)
                << e.what();
        }
    }
}

// $MCPT_VULKAN_WORKGROUP: another workgroup size renders the same image bit for bit (every
// pixel's samples are its own); a size past the device's limits is refused.
TEST(VulkanWorkgroup, OtherSizesRenderTheSameImage) {
    SKIP_WITHOUT_VULKAN();
    const Packed p = pack(make_builtin_scene("cornell"));
    const auto image = [&](const char* size) {
        const ScopedEnv env("MCPT_VULKAN_WORKGROUP", size);
        auto vk = open_vulkan();
        return render_on(*vk, p, 24, 4, 5u).mean_image();
    };
    const std::vector<float> base = image(nullptr);
    EXPECT_EQ(image("32"), base);
    EXPECT_EQ(image("96"), base);
    // Control: another seed is another image.
    {
        auto vk = open_vulkan();
        EXPECT_NE(render_on(*vk, p, 24, 4, 6u).mean_image(), base);
    }
    EXPECT_THROW(image("0"), Error);
    EXPECT_THROW(image("1000000"), Error);
}

#endif  // MCPT_WITH_VULKAN

}  // namespace
}  // namespace mcpt
