// The statistics behind `mcpt compare`: distributions against known values, and the tests'
// false-alarm rate and power on synthetic data with a known answer.
#include "common/analysis/stats.h"

#include <gtest/gtest.h>

#include <numeric>
#include <random>

#include "common/analysis/compare.h"

namespace mcpt::stats {
namespace {

TEST(Stats, DistributionsMatchTables) {
    EXPECT_NEAR(normal_cdf(1.959963985), 0.975, 1e-9);
    EXPECT_NEAR(normal_quantile(0.975), 1.959963985, 1e-8);
    EXPECT_NEAR(normal_quantile(1e-10), -6.361340902, 1e-6);
    EXPECT_NEAR(student_t_two_sided_p(2.228138852, 10), 0.05, 1e-8);  // t table, 10 dof
    EXPECT_NEAR(student_t_two_sided_p(63.65674116, 1), 0.01, 1e-8);
    EXPECT_NEAR(student_t_cdf(-1.0, 5), 0.1816087, 1e-6);
    EXPECT_DOUBLE_EQ(student_t_two_sided_p(0.0, 7), 1.0);
    EXPECT_NEAR(chi_square_upper_p(3.841458821, 1), 0.05, 1e-9);  // chi-square table
    EXPECT_NEAR(chi_square_upper_p(124.3421134, 100), 0.05, 1e-8);
    EXPECT_NEAR(chi_square_upper_p(18.30703805, 10), 0.05, 1e-8);
    EXPECT_NEAR(chi_square_upper_p(76.15389, 50), 0.01, 1e-6);
    EXPECT_NEAR(chi_square_upper_p(2.0, 2), std::exp(-1.0), 1e-12);
}

TEST(Stats, SidakAndBenjaminiHochberg) {
    EXPECT_NEAR(sidak_level(0.05, 1), 0.05, 1e-15);
    EXPECT_NEAR(sidak_level(0.05, 100), 1 - std::pow(0.95, 0.01), 1e-15);
    const std::vector<bool> d = benjamini_hochberg({0.001, 0.008, 0.039, 0.041, 0.3}, 0.05);
    EXPECT_EQ(d, (std::vector<bool>{true, true, false, false, false}));
}

// Benjamini-Hochberg against its definition (every p-value sorted): the same discoveries on
// mixtures of uniform and small p-values, ties included.
TEST(Stats, BenjaminiHochbergMatchesTheFullSort) {
    const auto oracle = [](const std::vector<double>& p, double q) {
        std::vector<size_t> order(p.size());
        std::iota(order.begin(), order.end(), 0);
        std::stable_sort(order.begin(), order.end(),
                         [&](size_t a, size_t b) { return p[a] < p[b]; });
        size_t k = 0;
        for (size_t r = 0; r < p.size(); ++r)
            if (p[order[r]] <= double(r + 1) / double(p.size()) * q) k = r + 1;
        std::vector<bool> d(p.size(), false);
        for (size_t r = 0; r < k; ++r) d[order[r]] = true;
        return d;
    };
    std::mt19937 rng(5);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    for (int trial = 0; trial < 20; ++trial) {
        std::vector<double> p(5000);
        for (double& x : p) {
            x = u(rng);
            if (x < 0.02 * trial / 20.0) x = 1e-6 * u(rng);     // signals
            if (trial % 5 == 0) x = std::round(x * 200) / 200;  // ties
        }
        for (double q : {0.01, 0.05, 0.2})
            EXPECT_EQ(benjamini_hochberg(p, q), oracle(p, q)) << trial << " " << q;
    }
}

// Welch's test on normal samples: 5% false alarms at level 0.05 when the means are equal
// (even with unequal variances), and a shift of 5 standard errors is found.
TEST(Stats, WelchFalseAlarmRateAndPower) {
    std::mt19937 rng(11);
    std::normal_distribution<double> noise(0.0, 1.0);
    auto sample = [&](double shift, double scale, int n, double& mean, double& var) {
        double s = 0, s2 = 0;
        for (int i = 0; i < n; ++i) {
            const double x = shift + scale * noise(rng);
            s += x, s2 += x * x;
        }
        mean = s / n;
        var = (s2 - n * mean * mean) / (n - 1);
    };
    int false_alarms = 0, detections = 0;
    const int trials = 4000;
    for (int t = 0; t < trials; ++t) {
        double ma, va, mb, vb;
        sample(0.0, 1.0, 32, ma, va);
        sample(0.0, 3.0, 32, mb, vb);  // unequal variances: Welch's case
        false_alarms += welch_test(ma, va, 32, mb, vb, 32).p < 0.05;
        sample(5.0 * std::sqrt(10.0 / 32.0), 3.0, 32, mb, vb);  // 5 standard errors away
        detections += welch_test(ma, va, 32, mb, vb, 32).p < 0.05;
    }
    EXPECT_NEAR(false_alarms / double(trials), 0.05, 0.012);
    EXPECT_GT(detections / double(trials), 0.98);
}

}  // namespace
}  // namespace mcpt::stats

namespace mcpt {
namespace {

// Noise-free pixels (a light seen directly) that differ by float rounding agree; the same
// pixels differing by 0.1% do not, and neither count toward the detectable bias.
TEST(Agreement, RoundingInNoiseFreePixelsIsNotBias) {
    BatchSet a, b;
    a.width = b.width = 16, a.height = b.height = 1, a.batches = b.batches = 32;
    a.mean.assign(16, 0.5), b.mean.assign(16, 0.5);
    a.var.assign(16, 0.01), b.var.assign(16, 0.01);
    for (int i = 0; i < 4; ++i) {
        a.mean[i] = 17.0, a.var[i] = 0;
        b.mean[i] = 17.0 * (1 + 3e-6), b.var[i] = 0;  // a few float ulps
    }
    const Agreement same = test_agreement(a, b);
    EXPECT_TRUE(same.agree) << same.verdict();
    EXPECT_GT(same.detectable_bias, 0.01) << "noise-free pixels must not claim tiny limits";
    for (int i = 0; i < 4; ++i) b.mean[i] = 17.0 * 1.001;
    const Agreement biased = test_agreement(a, b);
    EXPECT_FALSE(biased.agree) << biased.verdict();
    EXPECT_EQ(biased.sidak_rejections, 4u);
}

// An A/A comparison seen in `compare cornell --a opencl --b opencl` at 1024x1024, 8 batches
// of 1 spp, one bounce: in one pixel on an edge every batch of A came out dark and every
// batch of B lit (chance: about 3 in 100,000 such pixels), and Welch's test gave p = 4e-10,
// a false DIFFER. Floored at what a permutation test of 8 + 8 batches can resolve, the pixel is
// no evidence; with 32 batches a side the same means and variances still are (control).
TEST(Agreement, FewBatchesOfAnEdgePixelAreNoEvidence) {
    const auto compare = [](int batches) {
        BatchSet a, b;
        a.width = b.width = 1000, a.height = b.height = 100;
        a.batches = b.batches = batches;
        a.mean.assign(100000, 0.3), b.mean.assign(100000, 0.3);
        a.var.assign(100000, 0.01), b.var.assign(100000, 0.01);
        a.mean[7] = 0.000172685667, a.var[7] = 2.38562716e-07;
        b.mean[7] = 0.116395066, b.var[7] = 4.75455068e-05;
        return test_agreement(a, b, 0.01);
    };
    const Agreement few = compare(8);
    EXPECT_TRUE(few.agree) << few.verdict();
    EXPECT_EQ(few.sidak_rejections, 0u);
    EXPECT_NEAR(few.min_p, 2.0 / 12870, 1e-9);  // 2 / C(16, 8)
    EXPECT_NE(few.verdict().find("with this few batches (at least 15 a side"), std::string::npos)
        << few.verdict();
    const Agreement many = compare(32);
    EXPECT_FALSE(many.agree) << many.verdict();
    EXPECT_EQ(many.sidak_rejections, 1u);
    EXPECT_EQ(many.verdict().find("with this few batches"), std::string::npos);
}

}  // namespace
}  // namespace mcpt
