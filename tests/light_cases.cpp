#include "light_cases.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <stdexcept>

#include "common/accel/kdtree.h"
#include "common/analysis/stats.h"
#include "test_util.h"

namespace mcpt::test {

Scene plane_scene(float albedo, float s, float h) {
    Scene scene;
    Material m;
    m.color = glm::vec3(albedo);
    scene.add_material(m);
    const glm::vec3 a(-s, 0, -s), b(-s, 0, s), c(s, 0, s), d(s, 0, -s);
    scene.triangles.push_back({a, b, c, 0});
    scene.triangles.push_back({a, c, d, 0});
    scene.camera.position = glm::vec3(0, 3 * h, 0);
    scene.camera.forward = glm::vec3(0, -1, 0);
    scene.camera.up = glm::vec3(0, 0, -1);
    scene.camera.yfov = float(2 * std::atan(0.8 * s / (3 * h)));
    scene.has_camera = true;
    return scene;
}

glm::dvec3 plane_point(const Camera& cam, double fx, double fy, double aspect) {
    const glm::dvec3 w = glm::normalize(glm::dvec3(cam.forward));
    const glm::dvec3 u = glm::normalize(glm::cross(w, glm::dvec3(cam.up)));
    const glm::dvec3 v = glm::cross(u, w);
    const double t = std::tan(0.5 * double(cam.yfov));
    const glm::dvec3 d = glm::normalize(w + u * (t * aspect * fx) + v * (t * fy));
    const glm::dvec3 o(cam.position);
    return o + d * (-o.y / d.y);
}

std::vector<double> expected_image(const Scene& scene, int size,
                                   const std::function<double(glm::dvec3)>& radiance) {
    std::vector<double> out(size_t(size) * size_t(size));
    constexpr int kSub = 32;
    for (int py = 0; py < size; ++py)
        for (int px = 0; px < size; ++px) {
            double sum = 0;
            for (int j = 0; j < kSub; ++j)
                for (int i = 0; i < kSub; ++i) {
                    const double fx = (px + (i + 0.5) / kSub) / size * 2 - 1;
                    const double fy = 1 - (py + (j + 0.5) / kSub) / size * 2;
                    sum += radiance(plane_point(scene.camera, fx, fy, 1.0));
                }
            out[size_t(py) * size_t(size) + size_t(px)] = sum / (kSub * kSub);
        }
    return out;
}

RenderResult render_case(const std::string& api, const Scene& scene_in, int size,
                         const CaseRender& how) {
    Scene scene = scene_in;
    // Next-event estimation alone, or weighted 1/2 everywhere, must reach the whole map.
    if (how.env_strategy == 1 || how.env_strategy == 4) scene.environment.compensated = false;
    GpuScene g = pack_scene(scene, build_kdtree(scene.triangles, TreeOptions{}));
    if (how.plant) how.plant(g);
    BackendOptions bo;
    bo.extra_defines = how.defines;
    bo.env_strategy = how.env_strategy;
    auto backend = test_backend(api, bo);
    RenderOptions o;
    o.width = size, o.height = size;
    o.spp = how.spp;
    o.max_depth = how.max_depth;
    o.seed = 5;
    o.light_scale = how.light_scale;
    return render(*backend, g, scene.camera, o);
}

int pixels_off(const RenderResult& r, const std::vector<double>& expected) {
    const double z_limit =
        stats::normal_quantile(1 - stats::sidak_level(1e-4, expected.size()) / 2);
    // Float rounding where the light fades to zero (a range's or a cone's edge): 1e-4 of the
    // brightest pixel, absolute.
    const double floor = 1e-4 * *std::max_element(expected.begin(), expected.end());
    int off = 0;
    for (size_t i = 0; i < expected.size(); ++i) {
        const double n = double(r.spp) - double(r.nonfinite[i]);
        const double mean = r.sum[3 * i] / n;
        const double var = std::max(0.0, r.sum_sq[3 * i] / n - mean * mean) * n / (n - 1);
        const double sigma = std::sqrt(var / n + std::pow(5e-4 * expected[i], 2) + floor * floor);
        const bool is_off = std::abs(mean - expected[i]) / sigma > z_limit;
        if (is_off && std::getenv("MCPT_TEST_VERBOSE"))
            std::printf("pixel %zu: mean %.6g expected %.6g sigma %.3g\n", i, mean, expected[i],
                        sigma);
        off += is_off;
    }
    return off;
}

int pixels_apart(const RenderResult& a, const RenderResult& b) {
    const size_t n = a.nonfinite.size();
    const double limit = stats::normal_quantile(1 - stats::sidak_level(1e-4, n) / 2);
    std::vector<double> mean_a(n), var_a(n), mean_b(n), var_b(n);
    const auto moments = [&](const RenderResult& r, std::vector<double>& m,
                             std::vector<double>& v) {
        for (size_t i = 0; i < n; ++i) {
            const double k = double(r.spp) - r.nonfinite[i];
            m[i] = r.sum[3 * i] / k;
            v[i] = std::max(0.0, r.sum_sq[3 * i] / k - m[i] * m[i]) / (k - 1);
        }
    };
    moments(a, mean_a, var_a), moments(b, mean_b, var_b);
    const double floor = 1e-4 * *std::max_element(mean_b.begin(), mean_b.end());
    int apart = 0;
    for (size_t i = 0; i < n; ++i)
        apart += std::abs(mean_a[i] - mean_b[i]) >
                 limit * std::sqrt(var_a[i] + var_b[i] + floor * floor);
    return apart;
}

double pixel_sample_variance(const RenderResult& r, size_t i) {
    const double k = double(r.spp) - double(r.nonfinite[i]);
    const double mean = r.sum[3 * i] / k;
    return std::max(0.0, r.sum_sq[3 * i] / k - mean * mean) * k / (k - 1);
}

double mean_sample_variance(const RenderResult& r) {
    double v = 0;
    const size_t n = r.nonfinite.size();
    for (size_t i = 0; i < n; ++i) v += pixel_sample_variance(r, i);
    return v / double(n);
}

double mean_sample_deviation_squared(const RenderResult& r) {
    double sum = 0;
    const size_t n = r.nonfinite.size();
    for (size_t i = 0; i < n; ++i) sum += std::sqrt(pixel_sample_variance(r, i));
    return (sum / double(n)) * (sum / double(n));
}

double image_z(const RenderResult& r, const std::vector<double>& expected) {
    double diff = 0, var = 0;
    for (size_t i = 0; i < expected.size(); ++i) {
        const double n = double(r.spp) - double(r.nonfinite[i]);
        diff += r.sum[3 * i] / n - expected[i];
        var += pixel_sample_variance(r, i) / n + std::pow(5e-4 * expected[i], 2);
    }
    return diff / std::sqrt(var);
}

RenderResult with_pixel_scaled(RenderResult r, size_t i, double factor) {
    for (size_t c = 0; c < 3; ++c) {
        r.sum[3 * i + c] *= factor;
        r.sum_sq[3 * i + c] *= factor * factor;
    }
    return r;
}

double polygon_irradiance(glm::dvec3 p, const std::vector<glm::dvec3>& poly, double radiance) {
    double sum = 0;
    for (size_t i = 0; i < poly.size(); ++i) {
        const glm::dvec3 a = glm::normalize(poly[i] - p);
        const glm::dvec3 b = glm::normalize(poly[(i + 1) % poly.size()] - p);
        const double angle = std::acos(std::clamp(glm::dot(a, b), -1.0, 1.0));
        sum += angle * glm::normalize(glm::cross(a, b)).y;
    }
    return 0.5 * radiance * std::abs(sum);
}

Environment map_with_sun(int w, int h, float sky, int x, int y, float sun) {
    Environment env;
    env.name = "test map";
    env.width = w, env.height = h;
    env.rgb.assign(size_t(w) * size_t(h) * 3, sky);
    for (int c = 0; c < 3; ++c) env.rgb[(size_t(y) * size_t(w) + size_t(x)) * 3 + size_t(c)] = sun;
    return env;
}

double bilinear_radiance(const Environment& env, double u, double v) {
    const int w = env.width, h = env.height;
    const double fx = u * w - 0.5, fy = v * h - 0.5;
    const int x0 = int(std::floor(fx)), y0 = int(std::floor(fy));
    const double tx = fx - x0, ty = fy - y0;
    const auto at = [&](int x, int y) {
        x = ((x % w) + w) % w, y = std::clamp(y, 0, h - 1);
        return double(env.rgb[(size_t(y) * size_t(w) + size_t(x)) * 3]);
    };
    return (at(x0, y0) * (1 - tx) + at(x0 + 1, y0) * tx) * (1 - ty) +
           (at(x0, y0 + 1) * (1 - tx) + at(x0 + 1, y0 + 1) * tx) * ty;
}

double upward_irradiance(const Environment& env) {
    // Per texel (nearest): how surfaces are lit by the map (lights.h).
    constexpr int kSub = 16;
    double e = 0;
    for (int y = 0; y < env.height * kSub; ++y) {
        const double theta = kPi * (y + 0.5) / (env.height * kSub);
        if (std::cos(theta) <= 0) continue;
        const double d_omega =
            (2 * kPi / env.width) * (kPi / (env.height * kSub)) * std::sin(theta);
        for (int x = 0; x < env.width; ++x)
            e += env.rgb[(size_t(y / kSub) * size_t(env.width) + size_t(x)) * 3] * std::cos(theta) *
                 d_omega;
    }
    return e;
}

void scale_pick_pmf(GpuScene& g, uint32_t prim, float factor) {
    bool found = false;
    for (gpu::GpuLight& l : g.lights)
        if (l.prim == prim) l.pmf *= factor, found = true;
    if (prim == LIGHT_ENVIRONMENT) g.params.env_pmf *= factor;
    if (!found) throw std::runtime_error("no packed light " + std::to_string(prim));
}

}  // namespace mcpt::test
