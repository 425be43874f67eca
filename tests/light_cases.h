// Analytic light scenes shared by the light suites: a Lambertian plane seen from above, the
// exact image of a radiance function over it, a render of a scene (with a planted defect in
// its packed lights, for controls), and the per-pixel and image-wide checks against exact.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include <glm/glm.hpp>

#include "common/render/backend.h"
#include "common/render/gpu_scene.h"
#include "common/render/render_loop.h"
#include "common/scene/scene.h"

namespace mcpt::test {

constexpr double kPi = 3.14159265358979323846;

// A Lambertian square of half-size s at y = 0 (front side up), seen from (0, 3h, 0) straight
// down (image right = +X, image up = -Z), the image inside the square.
Scene plane_scene(float albedo, float s, float h);

// The point of the plane y = 0 the camera ray through image point (fx, fy) meets.
glm::dvec3 plane_point(const Camera& cam, double fx, double fy, double aspect);

// Per pixel: the mean of `radiance` over the pixel (32 x 32 points), against the render.
std::vector<double> expected_image(const Scene& scene, int size,
                                   const std::function<double(glm::dvec3)>& radiance);

// How a test renders: seed 5, the light scale, a backend option and a change to the packed
// scene (a planted defect: a wrong light pick probability, say).
struct CaseRender {
    uint64_t spp = 256;
    uint32_t max_depth = 8;
    float light_scale = 1.f;
    std::string defines;        // OpenCL only
    uint32_t env_strategy = 0;  // BackendOptions::env_strategy
    std::function<void(GpuScene&)> plant;
};
RenderResult render_case(const std::string& api, const Scene& scene, int size,
                         const CaseRender& how = {});

// Pixels (channel 0) whose mean differs from `expected` beyond the Sidak-corrected z limit,
// counting the sample error and 0.05% for the expected value's own integration.
int pixels_off(const RenderResult& r, const std::vector<double>& expected);

// Pixels (channel 0) where two renders' means differ beyond Sidak's z at 1e-4 over the image
// (as pixels_off), each with its own standard error, and 1e-4 of the brightest pixel for
// float rounding where light fades to zero.
int pixels_apart(const RenderResult& a, const RenderResult& b);

// Pixel i's sample variance (channel 0; its finite samples, unbiased).
double pixel_sample_variance(const RenderResult& r, size_t i);

// The mean over pixels of one sample's variance (channel 0).
double mean_sample_variance(const RenderResult& r);

// The mean over pixels of one sample's standard deviation (channel 0), squared: a variance
// that a few pixels of huge variance (across a light's edge, where the camera's samples see
// the light or not) do not swamp, as they do the mean of the variances.
double mean_sample_deviation_squared(const RenderResult& r);

// The image's mean difference from `expected` over its standard error (sample error, and
// 0.05% for the expected value's integration): what a light 2% too bright cannot pass.
double image_z(const RenderResult& r, const std::vector<double>& expected);

// The render with pixel i's samples scaled by `factor` (sum by f, sum of squares by f^2), as
// a defect confined to one pixel would leave it.
RenderResult with_pixel_scaled(RenderResult r, size_t i, double factor);

// Irradiance at p (normal +Y) from a one-sided polygon of uniform radiance L facing it
// (Lambert's formula: L / 2 times the sum over edges of the angle they subtend times the
// cosine of their plane's normal with the surface normal).
double polygon_irradiance(glm::dvec3 p, const std::vector<glm::dvec3>& poly, double radiance);

// A map of w x h texels of radiance `sky`, with `sun` at texel (x, y).
Environment map_with_sun(int w, int h, float sky, int x, int y, float sun);

// The map's radiance (channel 0) at (u, v), bilinear between texel centres as the device reads
// it (u wraps, v clamps): written here, not taken from the device code.
double bilinear_radiance(const Environment& env, double u, double v);

// Irradiance of the upward plane under a map: the integral of L cos over the upper half, L
// per texel (nearest), as surfaces are lit.
double upward_irradiance(const Environment& env);

// The packed light of `prim` (LIGHT_* bits, gpu_scene.h): its pick probability, as the
// device reads it, multiplied by `factor` (the pick itself unchanged).
void scale_pick_pmf(GpuScene& g, uint32_t prim, float factor);

}  // namespace mcpt::test
