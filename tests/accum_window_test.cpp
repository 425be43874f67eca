// Images whose sums exceed the device's largest buffer render through a window of the
// accumulation buffer (gpu_scene.h): the device holds one tile's sums and path state, read
// back after each round. The result is the very image the whole-image buffer gives
// (reproducible mode: same samples, same float sums in the same groups), on both APIs.
#include <gtest/gtest.h>

#include <cstdlib>

#include "common/render/session.h"
#include "common/scene/scene_load.h"
#include "test_util.h"

namespace mcpt {
namespace {

class AccumWindow : public ::testing::TestWithParam<std::string> {};

std::vector<float> render_image(const std::string& api, uint64_t max_buffer_bytes,
                                std::string* layout, uint64_t spp = 20) {
    BackendOptions o;
    o.max_buffer_bytes = max_buffer_bytes;
    Session s(test::test_backend(api, o));
    s.set_scene(load_scene("cornell"));
    s.settings().width = 48, s.settings().height = 40;
    s.settings().reproducible = true;
    s.settings().seed = 5;
    // 6 samples, then on to 20: the window renders the group that 6 cut short again whole.
    EXPECT_EQ(s.render(1e6, 0, 6).spp, 6u);
    EXPECT_EQ(s.render(1e6, 0, spp).spp, spp);
    *layout = s.backend().layout();
    return s.image_rgba32f();
}

TEST_P(AccumWindow, WindowedBufferGivesTheWholeImageBuffersImage) {
    const uint64_t small = 64 << 10;  // 64 KiB: windows of 481 pixels, 4 tiles of 480
    ASSERT_TRUE(accum_layout(48 * 40, small).window);
    std::string whole_layout, window_layout;
    const std::vector<float> whole = render_image(GetParam(), 0, &whole_layout);
    const std::vector<float> windowed = render_image(GetParam(), small, &window_layout);
    EXPECT_EQ(whole_layout.find("window"), std::string::npos) << whole_layout;
    EXPECT_NE(whole_layout.find("exact sums on the device"), std::string::npos) << whole_layout;
    EXPECT_NE(window_layout.find("accumulation in windows of 481 pixels"), std::string::npos)
        << window_layout;
    EXPECT_EQ(whole, windowed);
}

// Reproducible groups added exactly on the device (fold_sums.h) and on the host (where the
// exact sums do not fit beside the others): the same image, bit for bit, over several groups.
TEST_P(AccumWindow, ExactSumsOnTheDeviceGiveTheHostsImage) {
    const uint64_t npix = 48 * 40;
    const AccumLayout plain = accum_layout(npix, 0);
    const uint64_t no_room = plain.bytes + 16 * npix;  // the sums fit, the exact sums do not
    ASSERT_FALSE(accum_layout(npix, no_room).window);
    ASSERT_EQ(accum_layout(npix, no_room, true).exact_pixels, 0u);
    std::string device_layout, host_layout;
    const std::vector<float> device = render_image(GetParam(), 0, &device_layout, 70);
    const std::vector<float> host = render_image(GetParam(), no_room, &host_layout, 70);
    EXPECT_NE(device_layout.find("exact sums on the device"), std::string::npos) << device_layout;
    EXPECT_EQ(host_layout.find("exact sums"), std::string::npos) << host_layout;
    EXPECT_EQ(device, host);
    // Negative control: one sample more is another image.
    std::string other_layout;
    EXPECT_NE(render_image(GetParam(), 0, &other_layout, 71), device);
}

// OpenCL's read-backs through pinned memory (GPUs; $MCPT_PINNED_READBACK=1 takes the path on
// PoCL): the same sums, bit for bit, with the exact sums folded on the device (read_exact)
// and on the host (read_accum), and the reads from staging memory whole.
RenderResult render_sums(bool pinned, uint64_t max_buffer_bytes, std::string* layout) {
    setenv("MCPT_PINNED_READBACK", pinned ? "1" : "0", 1);
    BackendOptions o;
    o.max_buffer_bytes = max_buffer_bytes;
    Session s(test::test_backend("opencl", o));
    s.set_scene(load_scene("cornell"));
    s.settings().width = 48, s.settings().height = 40;
    s.settings().reproducible = true;
    s.settings().seed = 5;
    EXPECT_EQ(s.render(1e6, 0, 70).spp, 70u);
    unsetenv("MCPT_PINNED_READBACK");
    *layout = s.backend().layout();
    return s.result();
}

TEST(PinnedReadBack, GivesTheSameSums) {
    const uint64_t npix = 48 * 40;
    const uint64_t no_room = accum_layout(npix, 0).bytes + 16 * npix;
    for (const uint64_t max_bytes : {uint64_t(0), no_room}) {
        std::string plain_layout, pinned_layout;
        const RenderResult plain = render_sums(false, max_bytes, &plain_layout);
        const RenderResult pinned = render_sums(true, max_bytes, &pinned_layout);
        EXPECT_EQ(plain_layout.find("pinned"), std::string::npos) << plain_layout;
        EXPECT_NE(pinned_layout.find("pinned read-back"), std::string::npos) << pinned_layout;
        EXPECT_EQ(plain.sum, pinned.sum) << "buffer limit " << max_bytes;
        EXPECT_EQ(plain.sum_sq, pinned.sum_sq) << "buffer limit " << max_bytes;
        EXPECT_EQ(plain.nonfinite, pinned.nonfinite) << "buffer limit " << max_bytes;
        EXPECT_EQ(plain.rays, pinned.rays) << "buffer limit " << max_bytes;
    }
}

INSTANTIATE_TEST_SUITE_P(Backends, AccumWindow, ::testing::ValuesIn(test::test_apis()),
                         [](const auto& info) { return info.param; });

}  // namespace
}  // namespace mcpt
