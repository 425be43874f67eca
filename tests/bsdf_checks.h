// Checks of BSDFs written in the device dialect, run as C++ (microfacet_test.cpp,
// layers_test.cpp): directions, a hemisphere's quadrature, the chi-square of sampled
// directions against their density, and directional albedo by sampling and by quadrature.
#ifndef MCPT_TESTS_BSDF_CHECKS_H
#define MCPT_TESTS_BSDF_CHECKS_H

#include <cmath>
#include <functional>
#include <random>
#include <vector>

#include "common/analysis/stats.h"
#include "common/gpu/bsdf.h"

namespace mcpt::gpu {

constexpr double kPi = 3.14159265358979323846;

inline vec3 direction(double theta, double phi) {
    return V3(std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi), std::cos(theta));
}

inline vec3 outgoing(float cos_o) {
    return V3(std::sqrt(1.f - cos_o * cos_o), 0.f, cos_o);
}

// The integral of g over the upper hemisphere: a midpoint rule in (theta, phi), fine enough
// for lobes down to alpha = 0.04.
inline double hemisphere_integral(const std::function<double(vec3)>& g, int n_theta = 600,
                                  int n_phi = 600) {
    const double dt = 0.5 * kPi / n_theta, dp = 2 * kPi / n_phi;
    double sum = 0;
    for (int i = 0; i < n_theta; ++i) {
        const double theta = (i + 0.5) * dt;
        double ring = 0;
        for (int j = 0; j < n_phi; ++j) ring += g(direction(theta, (j + 0.5) * dp));
        sum += ring * std::sin(theta);
    }
    return sum * dt * dp;
}

// Chi-square of sampled directions against a pdf over equal-solid-angle cells: `bands` bands
// of cos theta in [cos_lo, 1] (0: the upper hemisphere, -1: the sphere) by 48 sectors, and one
// cell for "no sample" (a direction the pdf gives 0). Each cell's probability is the pdf
// integrated over it (a 16 x 16 midpoint rule in (theta, phi)).
using SampleFn = std::function<vec3(vec3 u)>;
using PdfFn = std::function<float(vec3 wi)>;
inline double direction_p_value(const SampleFn& sample, const PdfFn& pdf, int bands, float cos_lo,
                                unsigned seed, int n = 400000) {
    const int nc = bands, np = 48;
    const float span = 1.f - cos_lo;
    std::vector<double> observed(nc * np + 1, 0.0), expected(nc * np + 1, 0.0);
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> uni(0.f, 1.f);
    for (int i = 0; i < n; ++i) {
        const vec3 wi = sample(V3(uni(rng), uni(rng), uni(rng)));
        if (!(pdf(wi) > 0.f)) {
            observed[nc * np] += 1;
            continue;
        }
        const int c = std::min(nc - 1, int((1.f - wi.z) / span * nc));
        double phi = std::atan2(double(wi.y), double(wi.x));
        if (phi < 0) phi += 2 * kPi;
        observed[c * np + std::min(np - 1, int(phi / (2 * kPi) * np))] += 1;
    }
    double total = 0;
    for (int c = 0; c < nc; ++c) {
        const double t0 = std::acos(1.0 - double(span) * c / nc);
        const double t1 = std::acos(1.0 - double(span) * (c + 1) / nc);
        for (int p = 0; p < np; ++p) {
            const double p0 = 2 * kPi * p / np, p1 = 2 * kPi * (p + 1) / np;
            double sum = 0;
            const int k = 16;
            for (int x = 0; x < k; ++x)
                for (int y = 0; y < k; ++y) {
                    const double theta = t0 + (x + 0.5) * (t1 - t0) / k;
                    const double phi = p0 + (y + 0.5) * (p1 - p0) / k;
                    sum += pdf(direction(theta, phi)) * std::sin(theta);
                }
            const double prob = sum * (t1 - t0) * (p1 - p0) / (k * k);
            expected[c * np + p] = prob * n;
            total += prob;
        }
    }
    expected[nc * np] = std::max(0.0, 1.0 - total) * n;
    return stats::chi_square_test(observed, expected);
}

// Directional albedo E(wo) of a BSDF in the upper hemisphere, two ways: the mean sampling
// weight f cos / pdf (what the path tracer multiplies by; `pdf` the density it divides by)
// over n draws of `sample`, and quadrature of f cos (when `integrate`).
struct Albedo {
    double sampled = 0, sampled_error = 0, integrated = 0;
};
struct BsdfDraws {
    std::function<vec3(vec3 wo, vec3 u)> sample;
    std::function<float(vec3 wo, vec3 wi)> pdf;
    std::function<vec3(vec3 wo, vec3 wi)> f;
};
inline Albedo directional_albedo(const BsdfDraws& b, float cos_o, int n, bool integrate,
                                 unsigned seed) {
    const vec3 wo = outgoing(cos_o);
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> uni(0.f, 1.f);
    double sum = 0, sum2 = 0;
    for (int i = 0; i < n; ++i) {
        const vec3 wi = b.sample(wo, V3(uni(rng), uni(rng), uni(rng)));
        double w = 0;
        if (wi.z > 0.f) {
            const float pdf = b.pdf(wo, wi);
            if (pdf > 0.f) w = mean_component(b.f(wo, wi)) * wi.z / pdf;
        }
        sum += w, sum2 += w * w;
    }
    Albedo a;
    a.sampled = sum / n;
    a.sampled_error = std::sqrt(std::max(0.0, sum2 / n - a.sampled * a.sampled) / n);
    if (integrate)
        a.integrated = hemisphere_integral(
            [&](vec3 wi) { return mean_component(b.f(wo, wi)) * wi.z; }, 900, 400);
    return a;
}

}  // namespace mcpt::gpu

#endif  // MCPT_TESTS_BSDF_CHECKS_H
