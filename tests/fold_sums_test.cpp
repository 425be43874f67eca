// The device's exact sums (common/gpu/fold_sums.h, compiled here as C++) against the host's
// (common/render/exact_sums.h): the same 128-bit value and the same range verdict for every
// kind of float (zeros, subnormals, each exponent up to the range's edge, Inf, NaN) and for
// sums at the edges of the range, bit for bit.
#include "common/gpu/fold_sums.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <limits>
#include <random>

#include "common/render/exact_sums.h"

namespace mcpt {
namespace {

ExactSum from_words(glm::uvec4 w) {
    ExactSum v;
    const uint32_t words[4] = {w.x, w.y, w.z, w.w};
    std::memcpy(&v, words, sizeof(v));
    return v;
}

glm::uvec4 to_words(ExactSum v) {
    uint32_t words[4];
    std::memcpy(words, &v, sizeof(v));
    return {words[0], words[1], words[2], words[3]};
}

float from_bits(uint32_t bits) {
    float f;
    std::memcpy(&f, &bits, 4);
    return f;
}

// The device's term equals the host's, and both agree on whether it fits.
void expect_same_term(float value) {
    ExactSum host = 0;
    const bool host_ok = to_exact(value, host);
    const gpu::ExactTerm device = gpu::exact_term(value);
    ASSERT_EQ(device.ok, host_ok) << value;
    if (host_ok) {
        ASSERT_TRUE(from_words(device.w) == host) << value;
    }
}

TEST(FoldSums, TermsEqualTheHostsForEveryExponent) {
    for (float v : {0.f, -0.f, 1.f, -1.f, 0.5f, 1e-30f, -3.3e-20f, 1e22f, 3.4e38f,
                    std::numeric_limits<float>::denorm_min(), -std::numeric_limits<float>::min(),
                    std::numeric_limits<float>::infinity(), -std::numeric_limits<float>::infinity(),
                    std::numeric_limits<float>::quiet_NaN()})
        expect_same_term(v);
    // Every exponent with mantissas at both ends and between, both signs: the shifts below,
    // across and above each 32-bit word, and the edge of the range (2^50 * 2^50).
    std::mt19937 rng(7);
    for (uint32_t e = 0; e < 256; ++e)
        for (uint32_t m : {0u, 1u, 0x7fffffu, 0x400000u, uint32_t(rng()) & 0x7fffffu,
                           uint32_t(rng()) & 0x7fffffu})
            for (uint32_t sign : {0u, 1u}) expect_same_term(from_bits(sign << 31 | e << 23 | m));
    expect_same_term(0x1p49f);                       // just inside: 2^99
    expect_same_term(std::nextafter(0x1p50f, 0.f));  // just inside
    expect_same_term(0x1p50f);                       // the first value out of range
}

TEST(FoldSums, SumsEqualTheHostsAtTheRangesEdges) {
    // Sums around +-2^126 (the high 64 bits at +-2^62), and carries across every word.
    const ExactSum edge = ExactSum(1) << 126;
    std::vector<ExactSum> values = {0,
                                    1,
                                    -1,
                                    edge - 1,
                                    -edge + 1,
                                    edge - 2,
                                    -(edge - 2),
                                    ExactSum(UINT32_MAX),
                                    ExactSum(UINT64_MAX),
                                    (ExactSum(1) << 96) - 1,
                                    -(ExactSum(1) << 96)};
    std::mt19937_64 rng(11);
    for (int i = 0; i < 200; ++i)
        values.push_back(ExactSum(int64_t(rng())) * (ExactSum(1) << (rng() % 62)));
    for (ExactSum a : values)
        for (ExactSum b : values) {
            ExactSum host = a;
            const bool host_ok = add_exact(host, b);
            const gpu::ExactTerm device = gpu::exact_add(to_words(a), to_words(b));
            ASSERT_EQ(device.ok, host_ok);
            if (host_ok) {
                ASSERT_TRUE(from_words(device.w) == host);
            }
        }
}

// from_exact() scales by multiplications: the bits of the two ldexp() calls it replaced.
TEST(FoldSums, FromExactEqualsTheLdexpForm) {
    std::mt19937_64 rng(5);
    for (int i = 0; i < 100000; ++i) {
        const ExactSum v = ExactSum(int64_t(rng())) * (ExactSum(1) << (rng() % 63)) +
                           ExactSum(rng() >> (rng() % 64));
        const double hi = double(int64_t(v >> 64)), lo = double(uint64_t(v));
        const double ldexp_form = std::ldexp(std::ldexp(hi, 64) + lo, -kExactFractionBits);
        ASSERT_EQ(from_exact(v), ldexp_form);
    }
}

TEST(FoldSums, PixelFoldAddsOrStoresAndCounts) {
    const gpu::ExactPixel zero{};
    gpu::FoldStep f = gpu::fold_pixel(glm::vec4(1.5f, -2.f, 0.f, 3.f),
                                      glm::vec4(2.25f, 4.f, 0.f, 4e9f), zero, FOLD_STORE);
    ASSERT_TRUE(f.ok);
    f = gpu::fold_pixel(glm::vec4(0.25f, 0.f, 0.f, 1.f), glm::vec4(0.0625f, 0.f, 0.f, 4e9f), f.px,
                        FOLD_ADD);
    ASSERT_TRUE(f.ok);
    EXPECT_DOUBLE_EQ(from_exact(from_words(f.px.w[0])), 1.75);
    EXPECT_DOUBLE_EQ(from_exact(from_words(f.px.w[1])), -2.0);
    EXPECT_DOUBLE_EQ(from_exact(from_words(f.px.w[3])), 2.3125);
    EXPECT_EQ(f.px.w[6].x, 4u);  // non-finite samples
    const uint64_t rays = f.px.w[6].z | uint64_t(f.px.w[6].w) << 32;
    EXPECT_EQ(rays, 8000000000u);  // the count carried into its high word
    // FOLD_STORE forgets what was there; a sum out of range is reported.
    f = gpu::fold_pixel(glm::vec4(1.f, 0.f, 0.f, 0.f), glm::vec4(0.f), f.px, FOLD_STORE);
    EXPECT_DOUBLE_EQ(from_exact(from_words(f.px.w[0])), 1.0);
    EXPECT_EQ(f.px.w[6], glm::uvec4(0u));
    EXPECT_FALSE(
        gpu::fold_pixel(glm::vec4(0.f), glm::vec4(3e38f, 0.f, 0.f, 0.f), zero, FOLD_ADD).ok);
}

}  // namespace
}  // namespace mcpt
