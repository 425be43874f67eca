// False-colour maps shared by the HTML reports (`compare --report`, `converge --report`) and
// the browser viewer, whose JavaScript mirrors them. Every channel is computed in double
// precision and rounded to nearest (halves away from zero, which JavaScript's Math.round
// matches for these non-negative values), so the same input gives the same bytes in both:
//
//   z_color(z): diverging, for signed z-scores (B - A).
//     a = min(|z|, 5) / 5
//     z >= 0: lerp(white (255, 255, 255), red  (204, 0, 0),   a)
//     z <  0: lerp(white (255, 255, 255), blue (0, 68, 204),  a)
//     NaN or +-infinity: magenta (255, 0, 255)
//     where lerp(w, e, a) = round(w + (e - w) * a) per channel.
//
//   sequential_color(t): for t in [0, 1] (clamped), a piecewise-linear ramp of 5 stops,
//     t = 0.00  (0, 0, 0)        black
//     t = 0.25  (30, 30, 120)    dark blue
//     t = 0.50  (150, 40, 110)   purple
//     t = 0.75  (245, 135, 30)   orange
//     t = 1.00  (255, 250, 220)  white-ish
//     k = min(floor(4t), 3), f = 4t - k: round(stop[k] + (stop[k+1] - stop[k]) * f);
//     NaN or +-infinity: magenta (255, 0, 255).
//
// linear_unit() and log_unit() turn a value into t for sequential_color().
#pragma once
#include <cstdint>
#include <functional>
#include <vector>

namespace mcpt {

struct Rgb8 {
    uint8_t r = 0, g = 0, b = 0;
    bool operator==(const Rgb8& o) const { return r == o.r && g == o.g && b == o.b; }
};

// |z| at which z_color() reaches its end colours.
constexpr double kZColorSaturation = 5.0;

// Signed z: white at 0, red for positive, blue for negative, saturated at |z| = 5.
Rgb8 z_color(float z);
// t in [0, 1] (clamped): black -> dark blue -> purple -> orange -> white-ish.
Rgb8 sequential_color(float t);

// (v - lo) / (hi - lo), not clamped (sequential_color clamps); non-finite v passes through.
float linear_unit(float v, float lo, float hi);
// (log10 v - log10 lo) / (log10 hi - log10 lo); v <= 0 gives 0 (below any lo > 0), non-finite
// v passes through. lo and hi must be positive.
float log_unit(float v, float lo, float hi);

// A per-pixel map (one float per pixel, top row first) as 8-bit RGB pixels (3 bytes per pixel,
// top row first), each through `color`.
std::vector<uint8_t> false_color_pixels(const std::vector<float>& map,
                                        const std::function<Rgb8(float)>& color);
// Linear radiance RGB (3 floats per pixel) times `exposure` as 8-bit sRGB (linear_to_srgb8 in
// image_io.h); a pixel with a non-finite channel is magenta, as in write_image()'s PNG.
std::vector<uint8_t> radiance_to_srgb8(const std::vector<float>& rgb, float exposure = 1.f);
// The reports' exposure for an image of this mean radiance: min(1, 0.5 / mean), 1 when the
// mean is not positive: 1 as `render -o .png` for ordinary scenes, and a bright one (the
// furnace, radiance 2) at mid-grey instead of clipped white.
float display_exposure(double mean_radiance);

}  // namespace mcpt
