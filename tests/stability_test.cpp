// Numerical stability: the same image at any scale and position within the documented
// range, on every backend (PoCL and lavapipe in CI).
#include <gtest/gtest.h>

#include <map>

#include "common/compare.h"
#include "test_scenes.h"
#include "test_util.h"

namespace mcpt {
namespace {

BatchSet render_scene(const std::string& api, Scene scene, uint32_t seed_base) {
    validate_scene(scene);
    const GpuScene g = pack_scene(scene, build_kdtree(scene.triangles, TreeOptions{}));
    auto backend = test::test_backend(api);
    RenderOptions o;
    o.width = 32, o.height = 32;
    BatchOptions bo;
    bo.batches = 32;
    bo.spp_per_batch = 8;
    bo.seed_base = seed_base;
    return render_batches(*backend, g, scene.camera, o, bo);
}

struct Placement {
    double scale;
    double offset;
};

class ScaleAndPosition : public ::testing::TestWithParam<std::tuple<std::string, Placement>> {};

TEST_P(ScaleAndPosition, CornellImageUnchanged) {
    const auto& [api, pl] = GetParam();
    // The unit scene once per backend.
    static std::map<std::string, BatchSet> unit;
    if (!unit.count(api)) unit[api] = render_scene(api, make_builtin_scene("cornell"), 1);
    const Scene moved = test::transform_scene(make_builtin_scene("cornell"), pl.scale,
                                              glm::dvec3(pl.offset, -0.5 * pl.offset, 0.25 * pl.offset));
    const BatchSet b = render_scene(api, moved, 777);
    const Agreement g = test_agreement(unit[api], b, 0.01);
    EXPECT_TRUE(g.agree) << api << ": scale " << pl.scale << " offset " << pl.offset << ": "
                         << g.verdict();
}

INSTANTIATE_TEST_SUITE_P(
    Range, ScaleAndPosition,
    ::testing::Combine(::testing::ValuesIn(test::test_apis()),
                       ::testing::Values(Placement{1e-4, 0}, Placement{1e-2, 0}, Placement{1e2, 0},
                                         Placement{1e5, 0}, Placement{1, 10}, Placement{1, 1e2},
                                         Placement{1, 1e3}, Placement{1e-4, 1e-2},
                                         Placement{1e5, 1e6}, Placement{1, 1e4})),
    [](const auto& info) {
        const Placement& p = std::get<1>(info.param);
        char buf[96];
        std::snprintf(buf, sizeof buf, "%s_Scale%gOffset%g", std::get<0>(info.param).c_str(),
                      p.scale, p.offset);
        std::string s(buf);
        for (char& c : s)
            if (!isalnum(static_cast<unsigned char>(c))) c = '_';
        return s;
    });

}  // namespace
}  // namespace mcpt
