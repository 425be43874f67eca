// The white furnace through OpenCL: every surface emits Le and reflects albedo rho, so the
// radiance everywhere is Le / (1 - rho). The estimate must match within its confidence
// interval, and the same check must reject a 2% brighter light and a biased kernel build.
#include <gtest/gtest.h>

#include "common/render/gpu_scene.h"
#include "common/scene/builtin_scenes.h"
#include "test_util.h"

namespace mcpt {
namespace {

constexpr double kZLimit = 4.5;  // two-sided p ~ 7e-6 per check: no false alarms in CI

struct FurnaceRun {
    test::MeanEstimate estimate;
    double exact = 0;
    uint64_t nonfinite = 0;
};

FurnaceRun render_furnace(float albedo, float light_scale, const std::string& defines,
                          uint64_t spp) {
    Scene scene = make_furnace_scene(albedo, 1.0f);
    validate_scene(scene);
    const GpuScene g = pack_scene(scene, build_kdtree(scene.triangles, TreeOptions{}));
    auto backend = test::test_opencl_backend(defines);
    RenderOptions o;
    o.width = 32, o.height = 32;
    o.spp = spp;
    o.max_depth = uint32_t(scene.max_depth_hint);
    o.light_scale = light_scale;
    o.seed = 7;
    const RenderResult r = render(*backend, g, scene.camera, o);
    return {test::pooled_mean(r), 1.0 / (1.0 - albedo), r.nonfinite_total};
}

class Furnace : public ::testing::TestWithParam<float> {};

TEST_P(Furnace, MatchesExactRadiance) {
    const FurnaceRun run = render_furnace(GetParam(), 1.f, "", 256);
    const double z = run.estimate.z(run.exact);
    RecordProperty("relative_std_error", std::to_string(run.estimate.std_error / run.exact));
    EXPECT_EQ(run.nonfinite, 0u);
    EXPECT_LT(std::abs(z), kZLimit) << "mean " << run.estimate.mean << " exact " << run.exact
                                    << " std error " << run.estimate.std_error;
    // The check is sharp enough for the negative controls: 2% is many standard errors.
    EXPECT_LT(run.estimate.std_error / run.exact, 0.02 / (2 * kZLimit));
}

TEST_P(Furnace, RejectsTwoPercentBrighterLight) {
    const FurnaceRun run = render_furnace(GetParam(), 1.02f, "", 256);
    EXPECT_GT(run.estimate.z(run.exact), kZLimit) << "a 2% brighter light went unnoticed";
}

TEST_P(Furnace, RejectsBiasedRussianRoulette) {
    const FurnaceRun run = render_furnace(GetParam(), 1.f, "-DMCPT_NEGATIVE_CONTROL_RR", 128);
    EXPECT_LT(run.estimate.z(run.exact), -kZLimit) << "unweighted roulette went unnoticed";
}

INSTANTIATE_TEST_SUITE_P(Albedo, Furnace, ::testing::Values(0.5f, 0.9f),
                         [](const auto& info) { return info.param == 0.5f ? "Rho050" : "Rho090"; });

}  // namespace
}  // namespace mcpt
