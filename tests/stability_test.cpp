// Numerical stability: the same image at any scale and position within the documented
// range, on every backend (PoCL and lavapipe in CI), through the k-d tree and (the extreme
// placements) the BVH.
#include <gtest/gtest.h>

#include <cstring>
#include <map>

#include "common/analysis/compare.h"
#include "test_scenes.h"
#include "test_util.h"

namespace mcpt {
namespace {

BatchSet render_scene(const std::string& api, Scene scene, uint32_t seed_base,
                      TreeKind tree = TreeKind::Sah) {
    validate_scene(scene);
    TreeOptions to;
    to.kind = tree;
    const GpuScene g = pack_scene(scene, build_kdtree(scene.triangles, to));
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
    bool bvh = false;  // the moved scene through the BVH (the unit scene: the k-d tree)
};

class ScaleAndPosition : public ::testing::TestWithParam<std::tuple<std::string, Placement>> {};

TEST_P(ScaleAndPosition, CornellImageUnchanged) {
    const auto& [api, pl] = GetParam();
    // The unit scene once per backend.
    static std::map<std::string, BatchSet> unit;
    if (!unit.count(api)) unit[api] = render_scene(api, make_builtin_scene("cornell"), 1);
    const Scene moved =
        test::transform_scene(make_builtin_scene("cornell"), pl.scale,
                              glm::dvec3(pl.offset, -0.5 * pl.offset, 0.25 * pl.offset));
    const BatchSet b = render_scene(api, moved, 777, pl.bvh ? TreeKind::Bvh : TreeKind::Sah);
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
                                         Placement{1e5, 1e6}, Placement{1, 1e4},
                                         Placement{1e-4, 0, true}, Placement{1e5, 1e6, true},
                                         Placement{1, 1e4, true})),
    [](const auto& info) {
        const Placement& p = std::get<1>(info.param);
        char buf[96];
        std::snprintf(buf, sizeof buf, "%s_Scale%gOffset%g%s", std::get<0>(info.param).c_str(),
                      p.scale, p.offset, p.bvh ? "Bvh" : "");
        std::string s(buf);
        for (char& c : s)
            if (!isalnum(static_cast<unsigned char>(c))) c = '_';
        return s;
    });

class AwkwardCamera : public ::testing::TestWithParam<std::string> {};

// The camera exactly on the root split plane of the tree renders what a camera a hair off
// it renders (every camera ray starts in the plane, its direction often crossing it).
TEST_P(AwkwardCamera, OnTheRootSplitPlane) {
    Scene scene = make_builtin_scene("cornell");
    const KdTree tree = build_kdtree(scene.triangles, TreeOptions{});
    const uint32_t axis = tree.nodes[0].flags & 3u;
    ASSERT_NE(axis, KD_LEAF);
    float split;
    std::memcpy(&split, &tree.nodes[0].split_or_offset, 4);
    // Inside the box, on the plane.
    scene.camera.position = glm::vec3(0.f, 1.f, 0.9f);
    scene.camera.position[axis] = split;
    Scene off = scene;
    off.camera.position[axis] = split + 1e-4f;
    const BatchSet on_plane = render_scene(GetParam(), scene, 11);
    const BatchSet near_plane = render_scene(GetParam(), off, 9000);
    EXPECT_EQ(on_plane.nonfinite, 0u);
    const Agreement g = test_agreement(near_plane, on_plane, 0.01);
    EXPECT_TRUE(g.agree) << GetParam() << ": " << g.verdict();
}

// The camera inside the glass sphere and inside the mirror sphere: every path starts inside
// closed geometry; no invalid samples, and a finite image: lit through the glass, exactly
// black in the closed mirror (no light leaks in through rounding).
TEST_P(AwkwardCamera, InsideGeometry) {
    for (int s = 0; s < 2; ++s) {
        Scene scene = make_builtin_scene("cornell");
        scene.camera.position = scene.spheres[size_t(s)].center;
        const BatchSet b = render_scene(GetParam(), scene, 21);
        EXPECT_EQ(b.nonfinite, 0u) << GetParam() << " sphere " << s;
        double sum = 0;
        for (double m : b.mean) {
            EXPECT_TRUE(std::isfinite(m));
            sum += m;
        }
        if (s == 0)
            EXPECT_GT(sum, 0.0) << GetParam() << ": the glass sphere lets light in";
        else
            EXPECT_EQ(sum, 0.0) << GetParam() << ": light leaked into the closed mirror";
    }
}

INSTANTIATE_TEST_SUITE_P(Backends, AwkwardCamera, ::testing::ValuesIn(test::test_apis()),
                         [](const auto& info) { return info.param; });

}  // namespace
}  // namespace mcpt
