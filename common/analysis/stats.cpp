#include "common/analysis/stats.h"

#include <algorithm>
#include <cmath>
#include <numeric>

namespace mcpt::stats {

namespace {

// Continued fraction of the regularized incomplete beta function (Lentz's method).
double beta_continued_fraction(double a, double b, double x) {
    const double tiny = 1e-300, eps = 1e-15;
    double c = 1, d = 1 - (a + b) * x / (a + 1);
    d = 1 / (std::abs(d) < tiny ? tiny : d);
    double h = d;
    for (int m = 1; m <= 500; ++m) {
        const double m2 = 2.0 * m;
        double aa = m * (b - m) * x / ((a + m2 - 1) * (a + m2));
        d = 1 + aa * d, c = 1 + aa / c;
        d = 1 / (std::abs(d) < tiny ? tiny : d), c = std::abs(c) < tiny ? tiny : c;
        h *= d * c;
        aa = -(a + m) * (a + b + m) * x / ((a + m2) * (a + m2 + 1));
        d = 1 + aa * d, c = 1 + aa / c;
        d = 1 / (std::abs(d) < tiny ? tiny : d), c = std::abs(c) < tiny ? tiny : c;
        const double delta = d * c;
        h *= delta;
        if (std::abs(delta - 1) < eps) break;
    }
    return h;
}

// Regularized incomplete beta I_x(a, b).
double incomplete_beta(double a, double b, double x) {
    if (x <= 0) return 0;
    if (x >= 1) return 1;
    const double log_front =
        std::lgamma(a + b) - std::lgamma(a) - std::lgamma(b) + a * std::log(x) + b * std::log1p(-x);
    if (x < (a + 1) / (a + b + 2))
        return std::exp(log_front) * beta_continued_fraction(a, b, x) / a;
    return 1 - std::exp(log_front) * beta_continued_fraction(b, a, 1 - x) / b;
}

}  // namespace

double normal_cdf(double z) {
    return 0.5 * std::erfc(-z / std::sqrt(2.0));
}

double normal_quantile(double p) {
    // Acklam's rational approximation, refined by one Halley step.
    if (p <= 0) return -INFINITY;
    if (p >= 1) return INFINITY;
    static const double a[] = {-3.969683028665376e+01, 2.209460984245205e+02,
                               -2.759285104469687e+02, 1.383577518672690e+02,
                               -3.066479806614716e+01, 2.506628277459239e+00};
    static const double b[] = {-5.447609879822406e+01, 1.615858368580409e+02,
                               -1.556989798598866e+02, 6.680131188771972e+01,
                               -1.328068155288572e+01};
    static const double c[] = {-7.784894002430293e-03, -3.223964580411365e-01,
                               -2.400758277161838e+00, -2.549732539343734e+00,
                               4.374664141464968e+00,  2.938163982698783e+00};
    static const double d[] = {7.784695709041462e-03, 3.224671290700398e-01, 2.445134137142996e+00,
                               3.754408661907416e+00};
    const double lo = 0.02425;
    double x;
    if (p < lo) {
        const double q = std::sqrt(-2 * std::log(p));
        x = (((((c[0] * q + c[1]) * q + c[2]) * q + c[3]) * q + c[4]) * q + c[5]) /
            ((((d[0] * q + d[1]) * q + d[2]) * q + d[3]) * q + 1);
    } else if (p <= 1 - lo) {
        const double q = p - 0.5, r = q * q;
        x = (((((a[0] * r + a[1]) * r + a[2]) * r + a[3]) * r + a[4]) * r + a[5]) * q /
            (((((b[0] * r + b[1]) * r + b[2]) * r + b[3]) * r + b[4]) * r + 1);
    } else {
        const double q = std::sqrt(-2 * std::log1p(-p));
        x = -(((((c[0] * q + c[1]) * q + c[2]) * q + c[3]) * q + c[4]) * q + c[5]) /
            ((((d[0] * q + d[1]) * q + d[2]) * q + d[3]) * q + 1);
    }
    const double e = normal_cdf(x) - p;
    const double u = e * std::sqrt(2 * M_PI) * std::exp(x * x / 2);
    return x - u / (1 + x * u / 2);
}

double student_t_two_sided_p(double t, double dof) {
    if (!std::isfinite(t)) return std::isnan(t) ? 1.0 : 0.0;
    return incomplete_beta(dof / 2, 0.5, dof / (dof + t * t));
}

double student_t_cdf(double t, double dof) {
    const double tail = 0.5 * student_t_two_sided_p(t, dof);
    return t < 0 ? tail : 1 - tail;
}

Welch welch_test(double mean_a, double var_a, double n_a, double mean_b, double var_b, double n_b) {
    Welch w;
    const double va = var_a / n_a, vb = var_b / n_b;
    w.std_error = std::sqrt(va + vb);
    if (!(w.std_error > 0)) {
        // No variance: equal means agree, different means are certain to differ.
        w.p = mean_a == mean_b ? 1.0 : 0.0;
        w.t = w.z = mean_a == mean_b ? 0.0 : (mean_a > mean_b ? INFINITY : -INFINITY);
        return w;
    }
    w.t = (mean_a - mean_b) / w.std_error;
    w.dof = (va + vb) * (va + vb) /
            (va * va / std::max(n_a - 1, 1.0) + vb * vb / std::max(n_b - 1, 1.0));
    w.p = student_t_two_sided_p(w.t, w.dof);
    // Signed z with the same two-sided tail probability.
    const double z = -normal_quantile(std::max(w.p, 1e-300) / 2);
    w.z = w.t < 0 ? -z : z;
    return w;
}

namespace {
// Regularized upper incomplete gamma Q(a, x): the series of P below a + 1, else the continued
// fraction of Q (modified Lentz).
double gamma_q(double a, double x) {
    if (!(x > 0)) return 1.0;
    const double log_prefix = a * std::log(x) - x - std::lgamma(a);
    if (x < a + 1) {
        double term = 1.0 / a, sum = term;
        for (int n = 1; n < 10000 && std::fabs(term) > std::fabs(sum) * 1e-16; ++n) {
            term *= x / (a + n);
            sum += term;
        }
        return std::max(0.0, 1.0 - sum * std::exp(log_prefix));
    }
    const double tiny = 1e-300;
    double b = x + 1 - a, c = 1 / tiny, d = 1 / b, h = d;
    for (int n = 1; n < 10000; ++n) {
        const double an = -n * (n - a);
        b += 2;
        d = an * d + b;
        if (std::fabs(d) < tiny) d = tiny;
        c = b + an / c;
        if (std::fabs(c) < tiny) c = tiny;
        d = 1 / d;
        const double delta = d * c;
        h *= delta;
        if (std::fabs(delta - 1) < 1e-16) break;
    }
    return std::exp(log_prefix) * h;
}
}  // namespace

double chi_square_upper_p(double x, double dof) {
    return gamma_q(0.5 * dof, 0.5 * x);
}

double chi_square_test(const std::vector<double>& observed, const std::vector<double>& expected) {
    double chi2 = 0, pooled_obs = 0, pooled_exp = 0;
    size_t cells = 0;
    for (size_t i = 0; i < std::min(observed.size(), expected.size()); ++i) {
        if (expected[i] < 5) {
            pooled_obs += observed[i], pooled_exp += expected[i];
            continue;
        }
        const double d = observed[i] - expected[i];
        chi2 += d * d / expected[i];
        ++cells;
    }
    if (pooled_exp > 0) {
        const double d = pooled_obs - pooled_exp;
        chi2 += d * d / pooled_exp;
        ++cells;
    }
    return cells < 2 ? 1.0 : chi_square_upper_p(chi2, double(cells - 1));
}

double sidak_level(double alpha, size_t m) {
    return -std::expm1(std::log1p(-alpha) / double(std::max<size_t>(m, 1)));
}

std::vector<bool> benjamini_hochberg(const std::vector<double>& p, double q) {
    const size_t m = p.size();
    // Only p-values up to q can be under a threshold (rank / m * q): those sorted alone have
    // the ranks they have among all (a million pixels, a few of them candidates).
    std::vector<size_t> order;
    for (size_t i = 0; i < m; ++i)
        if (p[i] <= q) order.push_back(i);
    std::sort(order.begin(), order.end(), [&](size_t a, size_t b) { return p[a] < p[b]; });
    size_t k = 0;  // the largest rank whose p-value is under its threshold
    for (size_t r = 0; r < order.size(); ++r)
        if (p[order[r]] <= double(r + 1) / double(m) * q) k = r + 1;
    std::vector<bool> discovery(m, false);
    for (size_t r = 0; r < k; ++r) discovery[order[r]] = true;
    return discovery;
}

}  // namespace mcpt::stats
