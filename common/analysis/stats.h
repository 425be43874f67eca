// Statistics for comparing renderers: Student t and normal distributions, Welch's t-test,
// Sidak and Benjamini-Hochberg corrections (Jung, Hanika & Dachsbacher, JCGT 2020), and the
// chi-square distribution for goodness-of-fit tests of sampling routines.
#pragma once
#include <cstddef>
#include <vector>

namespace mcpt::stats {

double normal_cdf(double z);
double normal_quantile(double p);  // inverse of normal_cdf, p in (0, 1)
// Two-sided p-value of a Student t statistic with `dof` degrees of freedom.
double student_t_two_sided_p(double t, double dof);
// One-sided P(T <= t).
double student_t_cdf(double t, double dof);

// P(X >= x) for X chi-square distributed with `dof` degrees of freedom.
double chi_square_upper_p(double x, double dof);

// Pearson's chi-square test of observed counts against expected counts (cells whose
// expected count is below 5 are pooled into one); returns the p-value.
double chi_square_test(const std::vector<double>& observed, const std::vector<double>& expected);

struct Welch {
    double t = 0, dof = 1, p = 1;  // two-sided p
    double z = 0;                   // the same evidence as a signed standard normal score
    double std_error = 0;           // of the difference of means
};
// Welch's test of equal means from two samples' means, variances and sizes.
Welch welch_test(double mean_a, double var_a, double n_a, double mean_b, double var_b,
                 double n_b);

// Per-test level that keeps the family-wise error at alpha over m independent tests.
double sidak_level(double alpha, size_t m);

// Benjamini-Hochberg: which of the p-values are discoveries at false discovery rate q.
std::vector<bool> benjamini_hochberg(const std::vector<double>& p, double q);

}  // namespace mcpt::stats
