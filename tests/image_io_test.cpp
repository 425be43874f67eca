// Image I/O: exact EXR round trips, 8-bit sRGB PNG output, and the errors write_image reports.
#include "common/io/image_io.h"

#include <gtest/gtest.h>
#include <stb_image.h>
#include <unistd.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <string>
#include <vector>

#include "common/error.h"
#include "common/io/atomic_file.h"

namespace mcpt {
namespace {

std::string temp_path(const std::string& name) {
    return ::testing::TempDir() + "mcpt_" + name;
}

uint32_t bits(float f) {
    uint32_t u;
    std::memcpy(&u, &f, sizeof(u));
    return u;
}

std::string file_bytes(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

// Runs `f`, expects mcpt::Error, and returns its message
template <typename F>
std::string error_of(F f) {
    try {
        f();
    } catch (const Error& e) {
        return e.what();
    }
    ADD_FAILURE() << "no mcpt::Error thrown";
    return "";
}

TEST(ImageIo, ExrRoundTripIsBitExact) {
    // A non-square image with distinct channels and extreme values
    const float lim_max = std::numeric_limits<float>::max();
    const float lim_min = std::numeric_limits<float>::min();
    const float denorm = std::numeric_limits<float>::denorm_min();
    const std::vector<float> special = {
        0.0f,  -0.0f,    1.0f,     0.5f,  lim_min,     denorm,   1e-30f,      1e-7f,  lim_max,
        1e30f, 65504.0f, 65520.0f, -2.5f, 3.14159265f, 1.0f / 3, 123456.789f, 7e-45f, 1e38f};
    const int w = 5, h = 3;
    std::vector<float> rgb(3 * w * h);
    for (size_t i = 0; i < rgb.size(); ++i)
        rgb[i] = i < special.size() ? special[i] : float(i) * 0.37f + 1e-3f * float(i % 7);
    const std::string path = temp_path("roundtrip.exr");
    write_image(path, w, h, rgb);

    int rw = 0, rh = 0;
    const std::vector<float> back = read_exr(path, rw, rh);
    ASSERT_EQ(rw, w);
    ASSERT_EQ(rh, h);
    ASSERT_EQ(back.size(), rgb.size());
    for (size_t i = 0; i < rgb.size(); ++i)
        EXPECT_EQ(bits(back[i]), bits(rgb[i])) << "value " << i << ": " << rgb[i];
}

TEST(ImageIo, ExrExtensionIsCaseInsensitive) {
    const std::string path = temp_path("upper.EXR");
    write_image(path, 1, 1, {1.0f, 2.0f, 3.0f});
    int w = 0, h = 0;
    EXPECT_EQ(read_exr(path, w, h), (std::vector<float>{1.0f, 2.0f, 3.0f}));
    EXPECT_EQ(file_bytes(path).substr(0, 4), std::string("\x76\x2f\x31\x01", 4));
}

TEST(ImageIo, SrgbMapping) {
    EXPECT_EQ(linear_to_srgb8(0.0f), 0);
    EXPECT_EQ(linear_to_srgb8(0.5f), 188);
    EXPECT_EQ(linear_to_srgb8(1.0f), 255);
    EXPECT_EQ(linear_to_srgb8(2.0f), 255);
    EXPECT_EQ(linear_to_srgb8(-1.0f), 0);
    EXPECT_EQ(linear_to_srgb8(0.001f), 3);   // linear segment: 12.92 * 0.001 * 255 = 3.29
    EXPECT_EQ(linear_to_srgb8(0.22f), 129);  // 1.055 * 0.22^(1/2.4) - 0.055 = 0.5064
    // Against the exact OETF over the whole range
    for (int i = 0; i <= 1000; ++i) {
        const double v = i / 1000.0;
        const double s = v <= 0.0031308 ? 12.92 * v : 1.055 * std::pow(v, 1 / 2.4) - 0.055;
        EXPECT_EQ(linear_to_srgb8(float(v)), int(std::lround(s * 255))) << v;
    }
}

TEST(ImageIo, PngIsEightBitSrgb) {
    // Row 0: grey levels 0, 0.5, 1, 2; row 1: distinct channels, NaN, +Inf, -Inf pixels
    const float nan = std::numeric_limits<float>::quiet_NaN();
    const float inf = std::numeric_limits<float>::infinity();
    const int w = 4, h = 2;
    const std::vector<float> rgb = {0, 0,    0, 0.5f, 0.5f, 0.5f, 1,   1, 1, 2, 2, 2,
                                    1, 0.5f, 0, 0.5f, nan,  0.5f, inf, 0, 0, 0, 0, -inf};
    const std::string path = temp_path("srgb.PNG");
    write_image(path, w, h, rgb);

    const std::string bytes = file_bytes(path);
    ASSERT_GT(bytes.size(), 8u);
    EXPECT_EQ(bytes.substr(0, 8), std::string("\x89PNG\r\n\x1a\n", 8));
    int rw = 0, rh = 0, comp = 0;
    unsigned char* px = stbi_load(path.c_str(), &rw, &rh, &comp, 3);
    ASSERT_NE(px, nullptr) << stbi_failure_reason();
    EXPECT_EQ(rw, w);
    EXPECT_EQ(rh, h);
    EXPECT_EQ(comp, 3);
    const std::vector<int> got(px, px + 3 * w * h);
    stbi_image_free(px);
    const std::vector<int> want = {0,   0,   0, 188, 188, 188, 255, 255, 255, 255, 255, 255,
                                   255, 188, 0, 255, 0,   255, 255, 0,   255, 255, 0,   255};
    EXPECT_EQ(got, want);
}

TEST(ImageIo, UnsupportedExtensionThrows) {
    for (const char* name : {"out.bmp", "out.jpg", "out", "out.exr.txt", "dir.png/out"}) {
        const std::string msg = error_of([&] { write_image(temp_path(name), 1, 1, {0, 0, 0}); });
        EXPECT_NE(msg.find("unsupported image format"), std::string::npos) << msg;
        EXPECT_NE(msg.find("use .exr or .png"), std::string::npos) << msg;
    }
}

TEST(ImageIo, UnwritablePathThrowsWithPath) {
    for (const std::string path :
         {"/nonexistent-mcpt-dir/out.exr", "/nonexistent-mcpt-dir/a.png"}) {
        const std::string msg = error_of([&] { write_image(path, 2, 2, std::vector<float>(12)); });
        EXPECT_NE(msg.find(path), std::string::npos) << msg;
    }
}

TEST(ImageIo, SizeMismatchThrows) {
    const std::string msg = error_of([] { write_image(temp_path("bad.exr"), 2, 2, {0, 0, 0}); });
    EXPECT_NE(msg.find("bad.exr"), std::string::npos) << msg;
    error_of([] { write_image(temp_path("empty.png"), 0, 0, {}); });
}

TEST(ImageIo, ReadExrErrorsThrow) {
    int w = 0, h = 0;
    const std::string missing = temp_path("missing.exr");
    EXPECT_NE(error_of([&] { read_exr(missing, w, h); }).find(missing), std::string::npos);
    const std::string png = temp_path("not_exr.exr");
    std::ofstream(png) << "not an EXR file";
    EXPECT_NE(error_of([&] { read_exr(png, w, h); }).find(png), std::string::npos);
}

}  // namespace
}  // namespace mcpt

namespace mcpt {

// Outputs are written whole or not at all: a writer that fails midway leaves neither a partial
// file under the final name nor its temporary file, and an older file there stays intact.
TEST(AtomicFile, FailedWriteLeavesTheOldFileAndNoTemporary) {
    const std::filesystem::path dir =
        std::filesystem::temp_directory_path() / ("mcpt_atomic_" + std::to_string(getpid()));
    std::filesystem::create_directories(dir);
    const std::string path = (dir / "out.csv").string();
    write_text_atomically(path, "old\n");
    EXPECT_THROW(write_atomically(path,
                                  [](const std::string& tmp) {
                                      std::ofstream(tmp) << "half a fi";
                                      throw Error("writer failed");
                                  }),
                 Error);
    std::ifstream in(path);
    const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    EXPECT_EQ(text, "old\n");
    int files = 0;
    for (const auto& e : std::filesystem::directory_iterator(dir)) files += e.is_regular_file();
    EXPECT_EQ(files, 1) << "a temporary file was left behind";
    // An image write that fails (no such folder) leaves nothing either.
    EXPECT_THROW(write_image((dir / "missing" / "x.png").string(), 1, 1, {0.f, 0.f, 0.f}), Error);
    write_text_atomically(path, "new\n");
    std::ifstream again(path);
    std::string line;
    std::getline(again, line);
    EXPECT_EQ(line, "new");
    std::filesystem::remove_all(dir);
}

}  // namespace mcpt
