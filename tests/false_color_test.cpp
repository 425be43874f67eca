// The false-colour maps the reports and the viewer share (common/io/false_color.h): their end
// points, rounding, clamping, monotony and non-finite input, byte for byte as documented.
#include "common/io/false_color.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "common/io/image_io.h"

namespace mcpt {
namespace {

constexpr Rgb8 kWhite{255, 255, 255}, kMagenta{255, 0, 255};

double luminance(const Rgb8& c) {
    return 0.2126 * c.r + 0.7152 * c.g + 0.0722 * c.b;
}

TEST(FalseColor, ZColorEndsAndRounding) {
    // White at 0, the documented ends at |z| = 5 and beyond, halves rounded up.
    EXPECT_EQ(z_color(0.f), kWhite);
    EXPECT_EQ(z_color(-0.f), kWhite);
    EXPECT_EQ(z_color(5.f), (Rgb8{204, 0, 0}));
    EXPECT_EQ(z_color(1e30f), (Rgb8{204, 0, 0}));
    EXPECT_EQ(z_color(-5.f), (Rgb8{0, 68, 204}));
    EXPECT_EQ(z_color(-7.f), (Rgb8{0, 68, 204}));
    EXPECT_EQ(z_color(2.5f), (Rgb8{230, 128, 128}));
    EXPECT_EQ(z_color(-2.5f), (Rgb8{128, 162, 230}));
}

TEST(FalseColor, ZColorIsMonotoneAndNonFiniteIsMagenta) {
    // Paler towards 0 on both sides; red only for B brighter, blue only for B darker.
    for (float z = 0.f; z < 5.f; z += 0.125f) {
        EXPECT_GE(z_color(z).g, z_color(z + 0.125f).g) << z;
        EXPECT_GE(z_color(-z).r, z_color(-z - 0.125f).r) << z;
        EXPECT_GE(z_color(z).r, z_color(z).b) << z;
        EXPECT_GE(z_color(-z).b, z_color(-z).r) << z;
    }
    EXPECT_EQ(z_color(std::numeric_limits<float>::quiet_NaN()), kMagenta);
    EXPECT_EQ(z_color(std::numeric_limits<float>::infinity()), kMagenta);
    EXPECT_EQ(z_color(-std::numeric_limits<float>::infinity()), kMagenta);
}

TEST(FalseColor, SequentialStopsAndClamping) {
    // The five stops exactly, a midpoint rounded, clamped outside [0, 1].
    EXPECT_EQ(sequential_color(0.f), (Rgb8{0, 0, 0}));
    EXPECT_EQ(sequential_color(0.25f), (Rgb8{30, 30, 120}));
    EXPECT_EQ(sequential_color(0.5f), (Rgb8{150, 40, 110}));
    EXPECT_EQ(sequential_color(0.75f), (Rgb8{245, 135, 30}));
    EXPECT_EQ(sequential_color(1.f), (Rgb8{255, 250, 220}));
    EXPECT_EQ(sequential_color(0.125f), (Rgb8{15, 15, 60}));
    EXPECT_EQ(sequential_color(0.625f), (Rgb8{198, 88, 70}));
    EXPECT_EQ(sequential_color(-3.f), sequential_color(0.f));
    EXPECT_EQ(sequential_color(7.f), sequential_color(1.f));
    EXPECT_EQ(sequential_color(std::numeric_limits<float>::quiet_NaN()), kMagenta);
    EXPECT_EQ(sequential_color(std::numeric_limits<float>::infinity()), kMagenta);
}

TEST(FalseColor, SequentialBrightensMonotonically) {
    // Brighter at every step, up to one rounding step of the blue channel (where it falls while
    // red and green rise); strictly from stop to stop.
    for (int i = 0; i < 400; ++i)
        EXPECT_LE(luminance(sequential_color(i / 400.f)),
                  luminance(sequential_color((i + 1) / 400.f)) + 0.0722 + 1e-9)
            << i;
    for (int k = 0; k < 4; ++k)
        EXPECT_LT(luminance(sequential_color(k / 4.f)), luminance(sequential_color((k + 1) / 4.f)));
}

TEST(FalseColor, Units) {
    EXPECT_FLOAT_EQ(linear_unit(0.5f, 0.f, 2.f), 0.25f);
    EXPECT_FLOAT_EQ(linear_unit(3.f, 1.f, 2.f), 2.f);  // not clamped here
    EXPECT_NEAR(log_unit(1e-3f, 1e-7f, 1e-1f), 2.f / 3.f, 1e-6f);
    EXPECT_NEAR(log_unit(1e-7f, 1e-7f, 1e-1f), 0.f, 1e-6f);
    EXPECT_FLOAT_EQ(log_unit(0.f, 1e-7f, 1e-1f), 0.f);
    EXPECT_FLOAT_EQ(log_unit(-1.f, 1e-7f, 1e-1f), 0.f);
    EXPECT_TRUE(std::isnan(log_unit(std::nanf(""), 1e-4f, 1.f)));
    EXPECT_EQ(sequential_color(log_unit(std::numeric_limits<float>::infinity(), 1e-4f, 1.f)),
              kMagenta);
}

TEST(FalseColor, MapPixelsKeepOrder) {
    // Three bytes per value, in the map's order (top row first).
    const std::vector<uint8_t> px = false_color_pixels({0.f, 5.f, -5.f}, z_color);
    EXPECT_EQ(px, (std::vector<uint8_t>{255, 255, 255, 204, 0, 0, 0, 68, 204}));
    EXPECT_TRUE(false_color_pixels({}, z_color).empty());
}

TEST(FalseColor, RadianceToSrgb8) {
    // linear_to_srgb8 per channel after the exposure; a non-finite pixel all magenta.
    const float nan = std::numeric_limits<float>::quiet_NaN();
    const std::vector<uint8_t> px =
        radiance_to_srgb8({0.f, 1.f, 0.2f, 0.25f, 4.f, -1.f, nan, 0.f, 0.f}, 2.f);
    ASSERT_EQ(px.size(), 9u);
    EXPECT_EQ(px[0], 0);
    EXPECT_EQ(px[1], 255);
    EXPECT_EQ(px[2], linear_to_srgb8(0.4f));
    EXPECT_EQ(px[3], linear_to_srgb8(0.5f));
    EXPECT_EQ(px[4], 255);
    EXPECT_EQ(px[5], 0);
    EXPECT_EQ((Rgb8{px[6], px[7], px[8]}), kMagenta);
    EXPECT_EQ(radiance_to_srgb8({0.5f, 0.5f, 0.5f})[0], linear_to_srgb8(0.5f));
}

TEST(FalseColor, DisplayExposure) {
    EXPECT_FLOAT_EQ(display_exposure(0.2), 1.f);
    EXPECT_FLOAT_EQ(display_exposure(2.0), 0.25f);
    EXPECT_FLOAT_EQ(display_exposure(0.0), 1.f);
    EXPECT_FLOAT_EQ(display_exposure(std::nan("")), 1.f);
}

}  // namespace
}  // namespace mcpt
