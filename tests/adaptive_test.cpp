// Adaptive sampling on the devices (PoCL and lavapipe in CI): its image has the expectation of
// the uniformly sampled image, because a pixel's count never depends on its own samples
// (common/render/adaptive.h); the same test must reject the variant whose counts follow the
// pixel's own warm-up.
#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <string>
#include <vector>

#include "common/analysis/stats.h"
#include "common/render/gpu_scene.h"
#include "common/scene/builtin_scenes.h"
#include "test_util.h"

namespace mcpt {
namespace {

constexpr int kSize = 48, kRenders = 10;
constexpr double kTLimit = 5.0;  // Welch's t, about 18 degrees of freedom: p ~ 1e-4

// The mean radiance of each of `kRenders` independent renders of the Cornell box (64 spp, the
// mean over pixels when adaptive).
std::vector<double> image_means(const std::string& api, bool adaptive, bool own_noise,
                                uint32_t seed) {
    const Scene scene = make_builtin_scene("cornell");
    const GpuScene g = pack_scene(scene, build_kdtree(scene.triangles, TreeOptions{}));
    std::unique_ptr<Backend> backend = test::test_backend(api);
    backend->load(g, kSize, kSize, false);
    std::vector<double> means;
    for (int k = 0; k < kRenders; ++k) {
        RenderOptions o;
        o.width = o.height = kSize;
        o.spp = 64;
        o.seed = seed + uint32_t(k);
        o.adaptive = adaptive;
        o.adaptive_own_noise = own_noise;
        means.push_back(render_loaded(*backend, g, scene.camera, o).mean_radiance());
    }
    return means;
}

// Welch's t of the difference of two samples' means.
double welch_t(const std::vector<double>& a, const std::vector<double>& b) {
    auto mean_var = [](const std::vector<double>& x, double& m, double& v) {
        m = 0, v = 0;
        for (double e : x) m += e;
        m /= double(x.size());
        for (double e : x) v += (e - m) * (e - m);
        v /= double(x.size() - 1);
    };
    double ma, va, mb, vb;
    mean_var(a, ma, va);
    mean_var(b, mb, vb);
    return stats::welch_test(ma, va, double(a.size()), mb, vb, double(b.size())).t;
}

class Adaptive : public ::testing::TestWithParam<std::string> {};

TEST_P(Adaptive, ImageHasTheUniformImagesExpectation) {
    const std::vector<double> uniform = image_means(GetParam(), false, false, 100);
    const std::vector<double> adaptive = image_means(GetParam(), true, false, 200);
    const double t = welch_t(adaptive, uniform);
    RecordProperty("t", std::to_string(t));
    EXPECT_LT(std::abs(t), kTLimit) << "adaptive sampling changed the image's expectation";
    // The negative control: counts that follow the pixel's own samples.
    const std::vector<double> own = image_means(GetParam(), true, true, 300);
    const double t_own = welch_t(own, uniform);
    RecordProperty("t_own_noise", std::to_string(t_own));
    EXPECT_GT(std::abs(t_own), kTLimit) << "the biased variant went unnoticed";
}

INSTANTIATE_TEST_SUITE_P(Backends, Adaptive, ::testing::ValuesIn(test::test_apis()),
                         [](const auto& info) { return info.param; });

}  // namespace
}  // namespace mcpt
