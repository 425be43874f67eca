// The Owen-scrambled Sobol sampler (common/gpu/sampler.h), run as the C++ build of the device
// code: its direction numbers, the net property at every power of two, uniformity across
// pixels, independence between dimension groups, and the integration error it buys. Each
// property check has a negative control: a sampler with the defect it looks for must fail it.
#include "common/gpu/sampler.h"

#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <vector>

#include "common/analysis/stats.h"

namespace mcpt::gpu {
namespace {

using Sampler = std::function<vec4(uint pixel, uint sample_index, uint group, uint seed)>;

// Direction numbers from the recurrence of a primitive polynomial of degree s with inner
// coefficients a and initial m (Bratley & Fox 1988), the first `bits`, as 32-bit fixed point.
std::vector<uint> directions(uint s, uint a, std::vector<uint> m, uint bits) {
    for (uint k = s; k < bits; ++k) {
        uint next = m[k - s] ^ (m[k - s] << s);
        for (uint i = 1; i < s; ++i)
            if ((a >> (s - 1 - i)) & 1u) next ^= m[k - i] << i;
        m.push_back(next);
    }
    std::vector<uint> v(bits);
    for (uint k = 0; k < bits; ++k) v[k] = m[k] << (31 - k);
    return v;
}

TEST(Sampler, SobolDirectionsFollowTheirPolynomials) {
    const auto d1 = directions(1, 0, {1}, SOBOL_BLOCK_BITS);
    const auto d2 = directions(2, 1, {1, 3}, SOBOL_BLOCK_BITS);
    const auto d3 = directions(3, 1, {1, 3, 1}, SOBOL_BLOCK_BITS);
    for (uint bit = 0; bit < SOBOL_BLOCK_BITS; ++bit) {
        const uvec4 r = sobol4_reversed(1u << bit);
        const uvec4 x(reverse_bits(r.x), reverse_bits(r.y), reverse_bits(r.z), reverse_bits(r.w));
        EXPECT_EQ(x.x, 0x80000000u >> bit) << "bit " << bit;
        EXPECT_EQ(x.y, d1[bit]) << "bit " << bit;
        EXPECT_EQ(x.z, d2[bit]) << "bit " << bit;
        EXPECT_EQ(x.w, d3[bit]) << "bit " << bit;
    }
    // Linear over GF(2): point a ^ b is point a ^ point b.
    EXPECT_EQ(sobol4_reversed(0x1234u ^ 0x0f0fu),
              sobol4_reversed(0x1234u) ^ sobol4_reversed(0x0f0fu));
}

TEST(Sampler, BitReversalAndScramblesAreBijective) {
    EXPECT_EQ(reverse_bits(1u), 0x80000000u);
    EXPECT_EQ(reverse_bits(0x12345678u), 0x1e6a2c48u);
    // On 16 bits: each scramble of the low bits maps [0, 2^16) onto itself.
    for (uint seed : {0u, 1u, 0xdeadbeefu}) {
        std::vector<bool> seen(1u << 16, false);
        for (uint i = 0; i < (1u << 16); ++i)
            seen[nested_uniform_scramble(i, seed) & 0xffffu] = true;
        for (uint i = 0; i < (1u << 16); ++i) ASSERT_TRUE(seen[i]) << "seed " << seed;
    }
}

// Whether samples [first, first + 2^k) of one pixel and group form a (0,k,2)-net in
// dimensions (d0, d1): every elementary interval of area 2^-k holds exactly one point.
// With d0 == d1: whether dimension d0 alone is stratified into 2^k intervals.
bool is_net(const Sampler& sample, uint pixel, uint group, uint seed, uint first, int k, int d0,
            int d1) {
    const uint n = 1u << k;
    std::vector<vec4> pts;
    for (uint i = 0; i < n; ++i) pts.push_back(sample(pixel, first + i, group, seed));
    for (int a = d0 == d1 ? k : 0; a <= k; ++a) {
        const uint nx = 1u << a, ny = 1u << (k - a);
        std::vector<int> count(n, 0);
        for (const vec4& p : pts) {
            const uint cx = uint(p[d0] * float(nx)), cy = uint(p[d1] * float(ny));
            if (++count[cy * nx + cx] > 1) return false;
        }
    }
    return true;
}

const Sampler sobol = [](uint p, uint i, uint g, uint s) { return sobol4(p, i, g, s); };
const Sampler independent = [](uint p, uint i, uint g, uint s) { return rng4(p, i, g, s); };
// Negative control: the index shuffled by a bijection of the block that does not keep aligned
// blocks together (a multiplication), so the first 2^k samples are no net.
const Sampler bad_shuffle = [](uint p, uint i, uint g, uint s) {
    const uvec4 h = pcg4d(UV4(p, g, s, 0u));
    const uvec4 x = sobol4_reversed((i * 0x9e37u + h.x) & 0xffffu);
    return vec4(uint_to_unit_float(reverse_bits(x.x)), uint_to_unit_float(reverse_bits(x.y)),
                uint_to_unit_float(reverse_bits(x.z)), uint_to_unit_float(reverse_bits(x.w)));
};

TEST(Sampler, EveryPowerOfTwoIsANet) {
    for (uint pixel : {0u, 1u, 777u, 65535u})
        for (uint group : {0u, 1u, 2u, 15u})
            for (uint seed : {0u, 12345u})
                for (int k = 0; k <= 10; ++k) {
                    // Dimensions 0 and 1 together; 2 and 3 each stratified.
                    ASSERT_TRUE(is_net(sobol, pixel, group, seed, 0, k, 0, 1))
                        << "pixel " << pixel << " group " << group << " 2^" << k;
                    ASSERT_TRUE(is_net(sobol, pixel, group, seed, 0, k, 2, 2));
                    ASSERT_TRUE(is_net(sobol, pixel, group, seed, 0, k, 3, 3));
                }
    // Past the first block of 2^16 samples the next block is a net of its own.
    for (int k = 0; k <= 8; ++k) EXPECT_TRUE(is_net(sobol, 5, 3, 9, 1u << 16, k, 0, 1));
    // Negative controls: independent uniforms, and a shuffle that breaks aligned blocks.
    EXPECT_FALSE(is_net(independent, 0, 0, 0, 0, 4, 0, 1));
    EXPECT_FALSE(is_net(bad_shuffle, 0, 0, 0, 0, 4, 0, 1));
    EXPECT_FALSE(is_net(independent, 0, 0, 0, 0, 4, 2, 2));
}

// Chi-square p-value of a 16 x 16 histogram of (first, second) over `n` draws.
double uniformity_p(const std::function<vec2(uint)>& draw, uint n) {
    const int cells = 16;
    std::vector<double> observed(cells * cells, 0.0);
    for (uint i = 0; i < n; ++i) {
        const vec2 u = draw(i);
        observed[size_t(int(u.y * cells) * cells + int(u.x * cells))] += 1;
    }
    const std::vector<double> expected(observed.size(), double(n) / (cells * cells));
    return stats::chi_square_test(observed, expected);
}

// One pixel's sample 0 is a uniform point, independent from pixel to pixel and seed to seed.
TEST(Sampler, FirstSamplesAreUniformAcrossPixels) {
    const double alpha = 1e-4;
    for (uint group : {0u, 7u}) {
        const double p = uniformity_p(
            [&](uint pixel) {
                const vec4 u = sobol4(pixel, 0, group, 3);
                return vec2(u.x, u.z);
            },
            65536);
        EXPECT_GT(p, alpha) << "group " << group;
    }
    EXPECT_GT(uniformity_p([](uint seed) { return vec2(sobol4(12, 0, 1, seed)); }, 65536), alpha);
    // Negative control: Sobol points without a scramble per pixel (the same in every pixel).
    EXPECT_LT(uniformity_p([](uint) { return vec2(sobol4(12, 0, 1, 3)); }, 65536), alpha);
}

// Two dimension groups of one pixel are independent of each other (Burley's padding): the
// joint histogram of their first dimensions is uniform.
TEST(Sampler, DimensionGroupsAreIndependent) {
    const double alpha = 1e-4;
    for (uint g : {1u, 2u, 9u}) {
        const double p = uniformity_p(
            [&](uint i) { return vec2(sobol4(40, i, 0, 5).x, sobol4(40, i, g, 5).x); }, 4096);
        EXPECT_GT(p, alpha) << "groups 0 and " << g;
        const double q = uniformity_p(
            [&](uint i) { return vec2(sobol4(40, i, 1, 5).y, sobol4(40, i, g + 1, 5).w); }, 4096);
        EXPECT_GT(q, alpha) << "groups 1 and " << g + 1;
    }
    // Negative control: both groups shuffle the index alike and differ only in the output
    // scramble, so their points are functions of one another.
    auto same_index = [](uint i, uint out_seed) {
        const uint index = nested_uniform_scramble(i, 0x1234567u) & 0xffffu;
        return uint_to_unit_float(nested_uniform_scramble(reverse_bits(index), out_seed));
    };
    EXPECT_LT(
        uniformity_p([&](uint i) { return vec2(same_index(i, 11), same_index(i, 29)); }, 4096),
        alpha);
}

// RMS error over 256 pixels of 256-sample estimates of a 2D integral.
double rms_error(const Sampler& sample, const std::function<double(double, double)>& f,
                 double exact) {
    double se = 0;
    const uint pixels = 256, n = 256;
    for (uint p = 0; p < pixels; ++p) {
        double sum = 0;
        for (uint i = 0; i < n; ++i) {
            const vec4 u = sample(p, i, 3, 1);
            sum += f(u.x, u.y);
        }
        se += (sum / n - exact) * (sum / n - exact);
    }
    return std::sqrt(se / pixels);
}

// What the sampler is for: at 256 samples, a smooth integrand and one with an edge (a light's
// boundary, a disk of radius 1/2) come out with far less error than from independent uniforms.
TEST(Sampler, IntegratesWithLessErrorThanIndependentSamples) {
    auto smooth = [](double x, double y) { return std::exp(-x * x - y); };
    const double smooth_exact = (std::sqrt(M_PI) / 2 * std::erf(1.0)) * (1 - std::exp(-1.0));
    auto disk = [](double x, double y) { return x * x + y * y < 0.25 ? 1.0 : 0.0; };
    const double disk_exact = M_PI / 16;
    const double s_sobol = rms_error(sobol, smooth, smooth_exact);
    const double s_indep = rms_error(independent, smooth, smooth_exact);
    const double d_sobol = rms_error(sobol, disk, disk_exact);
    const double d_indep = rms_error(independent, disk, disk_exact);
    std::printf("256 samples, RMS error: smooth %.3g (independent %.3g), disk %.3g (%.3g)\n",
                s_sobol, s_indep, d_sobol, d_indep);
    EXPECT_LT(s_sobol, 0.1 * s_indep);
    EXPECT_LT(d_sobol, 0.3 * d_indep);
    // Unbiased: the mean over pixels is within 4 standard errors of the exact value.
    double mean = 0;
    for (uint p = 0; p < 4096; ++p) mean += disk(sobol4(p, 0, 3, 1).x, sobol4(p, 0, 3, 1).y);
    mean /= 4096;
    EXPECT_NEAR(mean, disk_exact, 4 * std::sqrt(disk_exact * (1 - disk_exact) / 4096));
}

}  // namespace
}  // namespace mcpt::gpu
