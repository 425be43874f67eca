// Environment maps: read from float EXR (values far beyond half's range kept exactly), from
// DWAB-compressed EXR (Blender's own maps; OpenEXR), from Radiance .hdr, from memory; bad
// files refused with the reason; a map too large for the device halved with a warning, its
// mean radiance kept.
#include "common/scene/environment.h"

#include <gtest/gtest.h>
#include <stb_image_write.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <numeric>

#include "common/error.h"
#include "common/io/image_io.h"
#include "common/render/prepare.h"
#include "test_util.h"

#if MCPT_WITH_OPENEXR
#include <ImfChannelList.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfOutputFile.h>
#include <ImfRgbaFile.h>
#include <half.h>
#endif

namespace mcpt {
namespace {

namespace fs = std::filesystem;

fs::path temp(const std::string& name) {
    return test::temp_file(name);
}

// A w x h map: a sky brightening toward the top, a sun 1e6 at (3, 2), a dim texel 1e-6.
std::vector<float> test_map(int w, int h) {
    std::vector<float> rgb(size_t(w) * size_t(h) * 3);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x)
            for (int c = 0; c < 3; ++c)
                rgb[size_t((y * w + x) * 3 + c)] = 0.5f + float(h - y) / float(h) + 0.1f * float(c);
    const auto at = [&](int x, int y) {
        return size_t((std::min(y, h - 1) * w + std::min(x, w - 1)) * 3);
    };
    for (size_t c = 0; c < 3; ++c) rgb[at(3, 2) + c] = 1e6f;
    for (size_t c = 0; c < 3; ++c) rgb[at(7, 5) + c] = 1e-6f;
    return rgb;
}

std::string error_of(const std::function<void()>& f) {
    try {
        f();
    } catch (const Error& e) {
        return e.what();
    }
    return "";
}

TEST(Environment, FloatExrKeepsEveryValue) {
    const std::vector<float> rgb = test_map(32, 16);
    const std::string path = temp("sky.exr").string();
    write_image(path, 32, 16, rgb);
    const Environment env = load_environment(path);
    ASSERT_EQ(env.width, 32);
    ASSERT_EQ(env.height, 16);
    EXPECT_EQ(env.rgb, rgb);  // float channels: 1e6 and 1e-6 exactly
}

TEST(Environment, RadianceHdr) {
    const std::vector<float> rgb = test_map(32, 16);
    const std::string path = temp("sky.hdr").string();
    ASSERT_NE(stbi_write_hdr(path.c_str(), 32, 16, 3, rgb.data()), 0);
    const Environment env = load_environment(path);
    ASSERT_EQ(env.rgb.size(), rgb.size());
    for (size_t i = 0; i < rgb.size(); ++i)
        if (rgb[i] > 1e-3f) {
            EXPECT_NEAR(env.rgb[i] / rgb[i], 1.0, 0.01) << i;  // RGBE: 8 bits of mantissa
        }
}

// A run-length encoded .hdr that another program wrote (tests/data/blender_ramp.hdr: Blender
// 3.4's writer, 40 x 6, red a ramp across, green constant, blue by row from the top; its
// header has a comment and EXPOSURE=, its rows runs and dumps): accepted by check_radiance,
// every texel in place to RGBE's 8-bit mantissa of the brightest channel.
TEST(Environment, RadianceHdrWrittenByBlender) {
    const Environment env = load_environment(std::string(MCPT_TEST_DATA_DIR) + "/blender_ramp.hdr");
    ASSERT_EQ(env.width, 40);
    ASSERT_EQ(env.height, 6);
    for (int y = 0; y < 6; ++y)
        for (int x = 0; x < 40; ++x) {
            const float want[3] = {0.1f + 0.1f * float(x), 0.5f, 0.25f * float(y + 1)};
            const float top = std::max({want[0], want[1], want[2]});
            for (int c = 0; c < 3; ++c)
                EXPECT_NEAR(env.rgb[size_t((y * 40 + x) * 3 + c)], want[c], top / 128)
                    << "texel " << x << ", " << y << ", channel " << c;
        }
}

// Radiance .hdr files that stb_image 2.27 would loop on forever (a dump of length 0,
// CVE-2021-42715) or fill with zeros (cut short): refused as corrupt, at once.
TEST(Environment, CorruptRadianceHdrIsRefusedNotLoopedOn) {
    const std::string head = "#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 4 +X 64\n";
    const auto load = [&](const std::string& name, const std::string& body) {
        const std::string bytes = head + body;
        return error_of([&] {
            load_environment_memory(reinterpret_cast<const unsigned char*>(bytes.data()),
                                    bytes.size(), name);
        });
    };
    const std::string scanline("\x02\x02\x00\x40", 4);
    // A new-style scanline header, a dump count of 0 and the end of the file (issue 36).
    EXPECT_NE(load("zero.hdr", scanline + std::string(1, '\0')).find("corrupt"), std::string::npos);
    // The same with three stray bytes after the count.
    EXPECT_NE(load("stray.hdr", scanline + std::string("\0abc", 4)).find("dump of length 0"),
              std::string::npos);
    // A run past the end of the row, a row that ends early, rows missing.
    EXPECT_NE(load("run.hdr", scanline + "\xff\x01").find("past the end"), std::string::npos);
    EXPECT_NE(load("short.hdr", scanline + "\xc0\x01").find("ends in row 0"), std::string::npos);
    std::string row = scanline;
    for (int c = 0; c < 4; ++c) row += "\xc0\x01";  // 4 channels, a run of 64 each
    EXPECT_EQ(load("one_row.hdr", row + row + row + row), "");
    EXPECT_NE(load("three_rows.hdr", row + row + row).find("ends at row 3"), std::string::npos);
    // A file written by stb, cut in half; and whole (the control).
    const std::string path = temp("cut.hdr").string();
    const std::vector<float> rgb = test_map(32, 16);
    ASSERT_NE(stbi_write_hdr(path.c_str(), 32, 16, 3, rgb.data()), 0);
    EXPECT_EQ(error_of([&] { load_environment(path); }), "");
    fs::resize_file(path, fs::file_size(path) / 2);
    EXPECT_NE(error_of([&] { load_environment(path); }).find("corrupt"), std::string::npos);
    // Flat pixels (a width below 8): every byte must be there.
    const std::string flat = "#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 2 +X 4\n";
    const std::string px("\x80\x80\x80\x81", 4);
    std::string bytes = flat;
    for (int i = 0; i < 8; ++i) bytes += px;
    EXPECT_EQ(error_of([&] {
                  load_environment_memory(reinterpret_cast<const unsigned char*>(bytes.data()),
                                          bytes.size(), "flat.hdr");
              }),
              "");
    bytes.resize(bytes.size() - 1);
    EXPECT_NE(error_of([&] {
                  load_environment_memory(reinterpret_cast<const unsigned char*>(bytes.data()),
                                          bytes.size(), "flat.hdr");
              }).find("ends before its last pixel"),
              std::string::npos);
}

#if MCPT_WITH_OPENEXR
// Blender's studio lights are DWAB-compressed half floats, which tinyexr cannot read.
TEST(Environment, DwabCompressedExr) {
    const int w = 64, h = 32;
    std::vector<float> planes(size_t(w) * size_t(h) * 3);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x)
            for (int c = 0; c < 3; ++c)
                planes[size_t(c * w * h + y * w + x)] =
                    0.25f + 0.5f * float(y) / float(h) + 0.1f * float(c);
    const std::string path = temp("dwab.exr").string();
    {
        Imf::Header header(w, h);
        header.compression() = Imf::DWAB_COMPRESSION;
        Imf::FrameBuffer fb;
        std::vector<half> halves(planes.begin(), planes.end());
        for (int c = 0; c < 3; ++c) {
            header.channels().insert(std::string(1, "RGB"[c]), Imf::Channel(Imf::HALF));
            fb.insert(std::string(1, "RGB"[c]),
                      Imf::Slice(Imf::HALF, reinterpret_cast<char*>(&halves[size_t(c * w * h)]),
                                 sizeof(half), sizeof(half) * w));
        }
        Imf::OutputFile file(path.c_str(), header);
        file.setFrameBuffer(fb);
        file.writePixels(h);
    }
    const Environment env = load_environment(path);
    ASSERT_EQ(env.width, w);
    ASSERT_EQ(env.height, h);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x)
            for (int c = 0; c < 3; ++c)
                EXPECT_NEAR(env.rgb[size_t((y * w + x) * 3 + c)],
                            planes[size_t(c * w * h + y * w + x)], 0.01)
                    << x << "," << y;
}
#endif

#if MCPT_WITH_OPENEXR
// A grey (Y only) EXR lights as the same grey in R, G and B (a frame buffer maps a channel
// name to one slice: Y inserted three times filled B alone); luminance-chroma files (Y, RY,
// BY) come back as their colour. Both are ramps with every pixel its own value (a step of 1
// between rows, 0.05 between columns), so a flipped, repeated or shifted row or column fails.
TEST(Environment, GreyAndLuminanceChromaExr) {
    const int w = 16, h = 8;
    const auto ramp = [](int x, int y) { return 0.1f + 0.05f * float(x) + float(y); };
    const std::string grey = temp("grey.exr").string();
    {
        Imf::Header header(w, h);
        header.channels().insert("Y", Imf::Channel(Imf::FLOAT));
        std::vector<float> y(size_t(w) * h);
        for (int j = 0; j < h; ++j)
            for (int i = 0; i < w; ++i) y[size_t(j * w + i)] = ramp(i, j);
        Imf::FrameBuffer fb;
        fb.insert("Y", Imf::Slice(Imf::FLOAT, reinterpret_cast<char*>(y.data()), sizeof(float),
                                  sizeof(float) * w));
        Imf::OutputFile file(grey.c_str(), header);
        file.setFrameBuffer(fb);
        file.writePixels(h);
    }
    const Environment from_y = load_environment(grey);
    ASSERT_EQ(from_y.rgb.size(), size_t(w) * h * 3);
    for (int j = 0; j < h; ++j)
        for (int i = 0; i < w; ++i)
            for (int c = 0; c < 3; ++c)
                EXPECT_EQ(from_y.rgb[size_t((j * w + i) * 3 + c)], ramp(i, j)) << i << "," << j;
    // Luminance-chroma through OpenEXR's RGBA interface: one colour at every brightness, so
    // the 2x2-subsampled chroma is exact and only half floats' rounding is left.
    const std::string yc = temp("yc.exr").string();
    {
        std::vector<Imf::Rgba> px(size_t(w) * h);
        for (int j = 0; j < h; ++j)
            for (int i = 0; i < w; ++i) {
                const float v = ramp(i, j);
                px[size_t(j * w + i)] = Imf::Rgba(0.6f * v, 0.3f * v, 0.15f * v, 1.f);
            }
        Imf::RgbaOutputFile file(yc.c_str(), w, h, Imf::WRITE_YC);
        file.setFrameBuffer(px.data(), 1, size_t(w));
        file.writePixels(h);
    }
    const Environment from_yc = load_environment(yc);
    ASSERT_EQ(from_yc.rgb.size(), size_t(w) * h * 3);
    for (int j = 0; j < h; ++j)
        for (int i = 0; i < w; ++i) {
            const float v = ramp(i, j), *p = &from_yc.rgb[size_t((j * w + i) * 3)];
            EXPECT_NEAR(p[0], 0.6 * v, 0.01 * v) << i << "," << j;
            EXPECT_NEAR(p[1], 0.3 * v, 0.01 * v) << i << "," << j;
            EXPECT_NEAR(p[2], 0.15 * v, 0.01 * v) << i << "," << j;
        }
}
#endif

TEST(Environment, FromMemoryAsFromTheFile) {
    const std::string path = temp("memory.exr").string();
    write_image(path, 32, 16, test_map(32, 16));
    std::ifstream in(path, std::ios::binary);
    const std::string bytes{std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
    const Environment env = load_environment_memory(
        reinterpret_cast<const unsigned char*>(bytes.data()), bytes.size(), "asset");
    EXPECT_EQ(env.rgb, load_environment(path).rgb);
}

TEST(Environment, BadFilesAreRefusedWithTheReason) {
    EXPECT_NE(error_of([] { load_environment("/nonexistent.exr"); }).find("not a readable"),
              std::string::npos);
    const std::string junk = temp("junk.exr").string();
    std::ofstream(junk) << "not an image at all";
    EXPECT_NE(error_of([&] { load_environment(junk); }).find("not an OpenEXR or Radiance"),
              std::string::npos);
    // A NaN texel: counted, refused.
    std::vector<float> rgb = test_map(8, 4);
    rgb[5] = std::nanf("");
    const std::string nan = temp("nan.exr").string();
    write_image(nan, 8, 4, rgb);
    EXPECT_NE(error_of([&] { load_environment(nan); }).find("1 non-finite"), std::string::npos);
    // A cut file.
    const std::string cut = temp("cut.exr").string();
    write_image(cut, 32, 16, test_map(32, 16));
    fs::resize_file(cut, fs::file_size(cut) / 2);
    EXPECT_NE(error_of([&] { load_environment(cut); }), "");
    EXPECT_NE(error_of([] { constant_environment(glm::vec3(-1, 0, 0)); }).find(">= 0"),
              std::string::npos);
}

// Halving keeps the mean radiance; prepare_scene halves a map the device's largest buffer
// cannot hold, and says so.
TEST(Environment, TooLargeForTheDeviceIsHalvedWithAWarning) {
    Environment env;
    env.name = "big";
    env.width = 512, env.height = 256;
    env.rgb = test_map(512, 256);
    for (float& v : env.rgb) v = std::min(v, 100.f);
    const auto mean = [](const Environment& e) {
        return std::accumulate(e.rgb.begin(), e.rgb.end(), 0.0) / double(e.rgb.size());
    };
    Environment half = env;
    EXPECT_EQ(shrink_environment(half, environment_device_bytes(256, 128)), 1);
    EXPECT_EQ(half.width, 256);
    EXPECT_NEAR(mean(half) / mean(env), 1.0, 1e-6);

    Scene scene;
    scene.add_material(Material{});
    scene.triangles.push_back({glm::vec3(0), glm::vec3(1, 0, 0), glm::vec3(0, 1, 0), 0});
    scene.environment = env;
    DeviceInfo device;
    device.backend = "test";
    device.name = "a small device";
    device.memory.max_buffer_bytes = uint64_t(1) << 20;
    device.memory.max_buffer_name = "maxStorageBufferRange";
    const GpuScene g = prepare_scene(scene, device, tree_options("none"), 8, 8);
    EXPECT_EQ(g.params.env_width, 256u);
    EXPECT_EQ(g.params.env_height, 128u);
    ASSERT_EQ(g.warnings.size(), 1u);
    EXPECT_NE(g.warnings[0].find("512x256"), std::string::npos) << g.warnings[0];
    EXPECT_NE(g.warnings[0].find("downsampled to 256x128"), std::string::npos) << g.warnings[0];
    EXPECT_LE(shading_buffer_bytes(g), device.memory.max_buffer_bytes);
    // Nothing halved where it fits.
    device.memory.max_buffer_bytes = 0;
    EXPECT_TRUE(prepare_scene(scene, device, tree_options("none"), 8, 8).warnings.empty());
}

}  // namespace
}  // namespace mcpt
