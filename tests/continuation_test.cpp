// Paths carried across dispatches: a round run one bounce per dispatch (every path stopped and
// resumed at every bounce) gives the same sums as the same round run to the end in one
// dispatch, on both APIs: the same samples, each exactly once, the same rays.
#include <gtest/gtest.h>

#include "common/scene/builtin_scenes.h"
#include "test_util.h"

namespace mcpt {
namespace {

class Continuation : public ::testing::TestWithParam<std::string> {};

// One round of `spp` samples per pixel with `budget` bounces per dispatch; the device sums
// and the number of dispatches it took.
std::pair<std::vector<float>, int> round_sums(Backend& b, const Scene& scene, const GpuScene& g,
                                              int size, uint32_t spp, uint32_t budget) {
    b.load(g, size, size, false);
    gpu::GpuParams p = g.params;
    set_camera(p, scene.camera, size, size);
    p.max_depth = 8, p.rr_depth = 3, p.seed = 11, p.light_scale = 1.f;
    p.pixel_offset = 0, p.pixel_count = uint32_t(size * size);
    p.sample_offset = 0, p.samples_per_dispatch = spp, p.accumulate = 0;
    p.state_base = 0, p.state_slots = accum_layout(uint64_t(size) * size, 0).slots;
    p.bounce_budget = budget;
    p.round_start = 1;
    int dispatches = 1;
    while (b.dispatch(p) != 0) p.round_start = 0, ++dispatches;
    std::vector<float> sums;
    b.read_accum(sums, 0);
    return {sums, dispatches};
}

TEST_P(Continuation, OneBouncePerDispatchEqualsWholePaths) {
    Scene scene = make_builtin_scene("cornell");
    validate_scene(scene);
    const GpuScene g = pack_scene(scene, build_kdtree(scene.triangles, TreeOptions{}));
    auto b = test::test_backend(GetParam());
    const auto [whole, n_whole] = round_sums(*b, scene, g, 16, 4, 1u << 20);
    const auto [stepped, n_stepped] = round_sums(*b, scene, g, 16, 4, 1);
    EXPECT_EQ(n_whole, 1);
    EXPECT_GT(n_stepped, 8) << "every pixel stopped and resumed at each bounce of 4 samples";
    ASSERT_EQ(whole.size(), stepped.size());
    double rays_whole = 0, rays_stepped = 0;
    size_t differ = 0;
    for (size_t i = 0; i < whole.size(); ++i) {
        if (i % 8 == 7) rays_whole += whole[i], rays_stepped += stepped[i];
        const float tol = 1e-4f * std::max(1.f, std::max(std::abs(whole[i]), std::abs(stepped[i])));
        differ += std::abs(whole[i] - stepped[i]) > tol;
    }
    EXPECT_EQ(rays_whole, rays_stepped) << "a path re-run or lost between dispatches";
    EXPECT_EQ(differ, 0u) << "of " << whole.size() << " sums";
}

INSTANTIATE_TEST_SUITE_P(Backends, Continuation, ::testing::ValuesIn(test::test_apis()),
                         [](const auto& info) { return info.param; });

}  // namespace
}  // namespace mcpt
