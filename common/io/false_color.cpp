#include "common/io/false_color.h"

#include <algorithm>
#include <cmath>

#include "common/io/image_io.h"

namespace mcpt {

namespace {

constexpr Rgb8 kMagenta{255, 0, 255};

// round(w + (e - w) * a) per channel, in double precision (the viewer's JavaScript does this).
Rgb8 lerp(const Rgb8& w, const Rgb8& e, double a) {
    const auto mix = [a](uint8_t x, uint8_t y) {
        return uint8_t(std::clamp(std::lround(double(x) + (double(y) - double(x)) * a), 0L, 255L));
    };
    return {mix(w.r, e.r), mix(w.g, e.g), mix(w.b, e.b)};
}

}  // namespace

Rgb8 z_color(float z) {
    // Non-finite: magenta; else from white towards red (B brighter) or blue.
    if (!std::isfinite(z)) return kMagenta;
    const double a = std::min(std::abs(double(z)), kZColorSaturation) / kZColorSaturation;
    constexpr Rgb8 white{255, 255, 255}, red{204, 0, 0}, blue{0, 68, 204};
    return lerp(white, z >= 0 ? red : blue, a);
}

Rgb8 sequential_color(float t) {
    // The five stops of the header comment, evenly spaced.
    static constexpr Rgb8 stops[5] = {
        {0, 0, 0}, {30, 30, 120}, {150, 40, 110}, {245, 135, 30}, {255, 250, 220}};
    if (!std::isfinite(t)) return kMagenta;
    const double x = 4 * std::clamp(double(t), 0.0, 1.0);
    const int k = std::min(int(std::floor(x)), 3);
    return lerp(stops[k], stops[k + 1], x - k);
}

float linear_unit(float v, float lo, float hi) {
    if (!std::isfinite(v)) return v;
    return float((double(v) - lo) / (double(hi) - lo));
}

float log_unit(float v, float lo, float hi) {
    if (!std::isfinite(v)) return v;
    if (v <= 0) return 0.f;
    return float((std::log10(double(v)) - std::log10(double(lo))) /
                 (std::log10(double(hi)) - std::log10(double(lo))));
}

std::vector<uint8_t> false_color_pixels(const std::vector<float>& map,
                                        const std::function<Rgb8(float)>& color) {
    std::vector<uint8_t> out(3 * map.size());
    for (size_t i = 0; i < map.size(); ++i) {
        const Rgb8 c = color(map[i]);
        out[3 * i] = c.r, out[3 * i + 1] = c.g, out[3 * i + 2] = c.b;
    }
    return out;
}

std::vector<uint8_t> radiance_to_srgb8(const std::vector<float>& rgb, float exposure) {
    std::vector<uint8_t> out(rgb.size() / 3 * 3);
    for (size_t i = 0; i + 2 < rgb.size(); i += 3) {
        // A pixel with any non-finite channel is magenta; else each channel scaled and encoded.
        const float* p = &rgb[i];
        if (!std::isfinite(p[0]) || !std::isfinite(p[1]) || !std::isfinite(p[2])) {
            out[i] = kMagenta.r, out[i + 1] = kMagenta.g, out[i + 2] = kMagenta.b;
            continue;
        }
        for (int c = 0; c < 3; ++c) out[i + c] = linear_to_srgb8(p[c] * exposure);
    }
    return out;
}

float display_exposure(double mean_radiance) {
    if (!(mean_radiance > 0) || !std::isfinite(mean_radiance)) return 1.f;
    return float(std::min(1.0, 0.5 / mean_radiance));
}

}  // namespace mcpt
