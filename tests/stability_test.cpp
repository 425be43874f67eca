// Numerical stability: the same image at any scale and position within the documented
// range, through the OpenCL backend (PoCL in CI).
#include <gtest/gtest.h>

#include "common/compare.h"
#include "test_scenes.h"
#include "test_util.h"

namespace mcpt {
namespace {

BatchSet render_scene(Scene scene, uint32_t seed_base) {
    validate_scene(scene);
    const GpuScene g = pack_scene(scene, build_kdtree(scene.triangles, TreeOptions{}));
    auto backend = test::test_opencl_backend();
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

class ScaleAndPosition : public ::testing::TestWithParam<Placement> {};

TEST_P(ScaleAndPosition, CornellImageUnchanged) {
    static const BatchSet unit = render_scene(make_builtin_scene("cornell"), 1);
    const Placement pl = GetParam();
    const Scene moved = test::transform_scene(make_builtin_scene("cornell"), pl.scale,
                                              glm::dvec3(pl.offset, -0.5 * pl.offset, 0.25 * pl.offset));
    const BatchSet b = render_scene(moved, 777);
    const Agreement g = test_agreement(unit, b, 0.01);
    EXPECT_TRUE(g.agree) << "scale " << pl.scale << " offset " << pl.offset << ": " << g.verdict();
}

INSTANTIATE_TEST_SUITE_P(
    Range, ScaleAndPosition,
    ::testing::Values(Placement{1e-4, 0}, Placement{1e-2, 0}, Placement{1e2, 0}, Placement{1e5, 0},
                      Placement{1, 10}, Placement{1, 1e2}, Placement{1, 1e3}, Placement{1e-4, 1e-2},
                      Placement{1e5, 1e6}, Placement{1, 1e4}),
    [](const auto& info) {
        char buf[64];
        std::snprintf(buf, sizeof buf, "Scale%gOffset%g", info.param.scale, info.param.offset);
        std::string s(buf);
        for (char& c : s)
            if (!isalnum(static_cast<unsigned char>(c))) c = '_';
        return s;
    });

}  // namespace
}  // namespace mcpt
