#include "common/render/adaptive.h"

#include <algorithm>
#include <cmath>

#include "common/error.h"

namespace mcpt {

std::vector<double> adaptive_sigma(const RenderResult& first_half, const RenderResult& warm_up,
                                   bool own_noise) {
    const int w = warm_up.width, h = warm_up.height;
    const size_t npix = size_t(w) * size_t(h);
    if (first_half.width != w || first_half.height != h || warm_up.sum.size() != 3 * npix ||
        first_half.sum.size() != 3 * npix)
        throw Error("adaptive sampling: the warm-up's halves differ in size");
    // Per pixel: the squared difference of the halves' means, over the channels.
    std::vector<double> diff(npix, 0.0), sigma(npix, 0.0);
    for (size_t i = 0; i < npix; ++i) {
        const double n1 = first_half.pixel_samples(i) - first_half.nonfinite[i];
        const double n2 = warm_up.pixel_samples(i) - warm_up.nonfinite[i] - n1;
        if (n1 < 1 || n2 < 1) continue;
        for (int c = 0; c < 3; ++c) {
            const double a = first_half.sum[3 * i + c] / n1;
            const double b = (warm_up.sum[3 * i + c] - first_half.sum[3 * i + c]) / n2;
            diff[i] += (a - b) * (a - b) / 3;
        }
    }
    if (own_noise) {
        for (size_t i = 0; i < npix; ++i) sigma[i] = std::sqrt(diff[i]);
        return sigma;
    }
    // The mean over the pixel's neighbours within kAdaptiveRadius (a summed-area table),
    // the pixel itself left out (a 1x1 image has none: sigma 0, every pixel alike).
    const int R = kAdaptiveRadius;
    std::vector<double> sat((size_t(w) + 1) * (size_t(h) + 1), 0.0);
    auto at = [&](int x, int y) -> double& { return sat[size_t(y) * (w + 1) + x]; };
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x)
            at(x + 1, y + 1) = diff[size_t(y) * w + x] + at(x, y + 1) + at(x + 1, y) - at(x, y);
    for (int y = 0; y < h; ++y) {
        for (int x = 0; x < w; ++x) {
            const int x0 = std::max(0, x - R), x1 = std::min(w, x + R + 1);
            const int y0 = std::max(0, y - R), y1 = std::min(h, y + R + 1);
            const double s =
                at(x1, y1) - at(x0, y1) - at(x1, y0) + at(x0, y0) - diff[size_t(y) * w + x];
            const int k = (x1 - x0) * (y1 - y0) - 1;
            sigma[size_t(y) * w + x] = k > 0 ? std::sqrt(std::max(0.0, s) / k) : 0.0;
        }
    }
    return sigma;
}

std::vector<uint32_t> plan_samples(const std::vector<double>& sigma,
                                   const std::vector<double>& counts, uint64_t budget,
                                   uint32_t max_step) {
    const size_t npix = counts.size();
    std::vector<uint32_t> plan(npix, 0);
    if (npix == 0 || sigma.size() != npix || budget == 0 || max_step == 0) return plan;
    double total = double(budget);
    for (double n : counts) total += n;
    const double floor_count = kAdaptiveFloor * total / double(npix);
    // Each pixel's step s (its count n again, at most max_step), and the squared error it
    // removes per sample, (sigma^2 / n - sigma^2 / (n + s)) / s; the pixels under the floor first.
    auto step = [&](size_t i) { return std::clamp(counts[i], 1.0, double(max_step)); };
    std::vector<std::pair<double, uint32_t>> order(npix);
    for (size_t i = 0; i < npix; ++i) {
        const double n = std::max(1.0, counts[i]);
        const double removed = sigma[i] * sigma[i] / (n * (n + step(i)));
        order[i] = {counts[i] < floor_count ? HUGE_VAL : removed, uint32_t(i)};
    }
    std::sort(order.begin(), order.end(), [](const auto& a, const auto& b) {
        return a.first > b.first || (a.first == b.first && a.second < b.second);
    });
    // Steps in that order while the budget lasts (a pixel too dear is passed over); the first
    // one whatever it costs, so that every pass adds samples.
    double spent = 0;
    for (const auto& [removed, i] : order) {
        const double s = step(i);
        if (spent > 0 && spent + s > double(budget)) continue;
        plan[i] = uint32_t(s);
        spent += s;
    }
    return plan;
}

}  // namespace mcpt
