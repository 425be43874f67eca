// Ray queries on Vulkan (--tree rayquery: the driver traces against acceleration structures
// built on the device). ctest runs the RayQuery suite on Mesa 25's lavapipe, which has them
// (MCPT_TEST_RAY_QUERIES=1: their absence fails), and the RayQueryAbsent suite on Debian 12's
// own, which has none.
//  - The oracle: rays cast one by one on the device (GpuParams.ray_cast) against brute force
//    on the CPU (the same rays, cpu_cast_ray): the same closest triangle or sphere, t and the
//    barycentrics within bounds, or a tie (two primitives at one distance); any-hit answers
//    agree with the closest. Planted faults: a triangle left out of the structure, sphere
//    boxes shrunk to half: both caught.
//  - Images: the BVH and ray queries agree statistically on the device (glass and mirror
//    spheres, a mesh, a textured scene with cut-outs and lamps), and the test rejects a light
//    2% brighter on one side; `mcpt compare` A/Bs the two trace modes by per-side options.
//  - The furnace exact, the textured scene unchanged at every scale and position, and
//    --reproducible one file from one device, two, or two parts merged.
//  - Without ray queries: --tree rayquery is a clear error, and auto never picks them.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>

#include "common/accel/cpu_trace.h"
#include "common/analysis/compare.h"
#include "common/error.h"
#include "common/render/device_registry.h"
#include "common/render/prepare.h"
#include "common/scene/builtin_scenes.h"
#include "common/scene/gltf_loader.h"
#include "test_scenes.h"
#include "test_util.h"
#include "vulkan/vk_backend.h"

namespace mcpt {
namespace {

// ctest sets this where the Vulkan driver must have ray queries.
bool ray_queries_expected() {
    const char* e = std::getenv("MCPT_TEST_RAY_QUERIES");
    return e && std::string(e) == "1";
}

// The Vulkan device under test, which must have ray queries where ray_queries_expected().
#define VULKAN_WITH_RAY_QUERIES(backend, options)                                              \
    auto backend = test::test_backend("vulkan", options);                                      \
    if (!backend->device().ray_queries) {                                                      \
        if (ray_queries_expected()) FAIL() << backend->description() << " has no ray queries"; \
        GTEST_SKIP() << backend->description() << " has no ray queries";                       \
    }

struct NamedScene {
    std::string name;
    Scene scene;
};
std::vector<NamedScene> oracle_scenes() {
    std::vector<NamedScene> s;
    s.push_back({"cornell", make_builtin_scene("cornell")});
    s.push_back({"bumpy sphere", make_bumpy_sphere_scene(40)});
    s.push_back({"textured", load_gltf(std::string(MCPT_TEST_DATA_DIR) + "/textured.glb")});
    for (NamedScene& c : s) validate_scene(c.scene);
    return s;
}

// The device's answers for rays 0 .. n-1 of the scene (ray_cast.h).
struct DeviceCast {
    std::vector<gpu::Hit> closest;
    std::vector<uint32_t> any_prim;
    std::vector<uint32_t> status;
};
DeviceCast cast_on_device(Backend& backend, const GpuScene& g, uint32_t n) {
    backend.load(g, int(n), 1, false);
    gpu::GpuParams p = g.params;
    p.width = n, p.height = 1;
    p.pixel_offset = 0, p.pixel_count = n;
    p.ray_cast = 1;
    backend.dispatch(p);
    std::vector<float> out;
    backend.read_accum(out, n);
    DeviceCast d;
    const auto bits = [](float f) {
        uint32_t u;
        std::memcpy(&u, &f, 4);
        return u;
    };
    for (uint32_t i = 0; i < n; ++i) {
        const float* w = &out[size_t(i) * 8];
        gpu::Hit h{};
        h.t = w[0], h.prim = bits(w[1]), h.b1 = w[2], h.b2 = w[3];
        d.closest.push_back(h);
        d.any_prim.push_back(bits(w[4]));
        d.status.push_back(bits(w[5]));
    }
    return d;
}

// How the device's hits compare with brute force.
struct OracleCounts {
    uint32_t rays = 0, hits = 0;  // hits: rays that the oracle sees hit something
    uint32_t same = 0;            // the same primitive, t and barycentrics within bounds
    uint32_t ties = 0;            // another primitive at the same distance
    uint32_t differ = 0;          // anything else: a miss for a hit, a farther primitive
    uint32_t any_wrong = 0;       // any-hit's answer is not whether the ray hits at all
    uint32_t incomplete = 0;      // a status flag on the device
    std::string first_difference;
};

// t within 1e-4 relative (lavapipe's triangle test and ours are both single precision: a few
// ulps of t apart at most, and the rays here span a few units), barycentrics within 1e-3.
bool close_t(float a, float b) {
    return std::abs(a - b) <= 1e-4f * std::max(1.f, std::abs(b));
}

OracleCounts check_against_brute_force(const GpuScene& g, const DeviceCast& d) {
    OracleCounts c;
    for (uint32_t i = 0; i < d.closest.size(); ++i) {
        const gpu::Ray ray = cpu_cast_ray(g, i);
        const gpu::Hit want = cpu_trace(g, ray, false);
        const gpu::Hit& got = d.closest[i];
        c.rays += 1;
        c.hits += want.prim != NO_HIT;
        c.incomplete += d.status[i] != 0;
        if ((d.any_prim[i] != NO_HIT) != (want.prim != NO_HIT)) c.any_wrong += 1;
        bool same = got.prim == want.prim;
        if (same && want.prim != NO_HIT) {
            same = close_t(got.t, want.t);
            if ((want.prim & SPHERE_BIT) == 0u)
                same = same && std::abs(got.b1 - want.b1) <= 1e-3f &&
                       std::abs(got.b2 - want.b2) <= 1e-3f;
        }
        if (same) {
            c.same += 1;
        } else if (got.prim != NO_HIT && want.prim != NO_HIT && close_t(got.t, want.t)) {
            c.ties += 1;
        } else {
            c.differ += 1;
            if (c.first_difference.empty()) {
                c.first_difference = "ray " + std::to_string(i) + ": device prim " +
                                     std::to_string(got.prim) + " t " + std::to_string(got.t) +
                                     ", brute force prim " + std::to_string(want.prim) + " t " +
                                     std::to_string(want.t);
            }
        }
    }
    return c;
}

constexpr uint32_t kRays = 16384;

TEST(RayQuery, HitsAreBruteForces) {
    VULKAN_WITH_RAY_QUERIES(backend, BackendOptions{});
    for (const NamedScene& s : oracle_scenes()) {
        const GpuScene g =
            prepare_scene(s.scene, backend->device(), tree_options("rayquery"), int(kRays), 1);
        ASSERT_NE(g.params.scene_flags & SCENE_RAY_QUERY, 0u);
        const OracleCounts c = check_against_brute_force(g, cast_on_device(*backend, g, kRays));
        std::printf("%s: %u rays, %u hits; %u the same, %u ties, %u differ, %u any-hit wrong\n",
                    s.name.c_str(), c.rays, c.hits, c.same, c.ties, c.differ, c.any_wrong);
        EXPECT_GT(c.hits, kRays / 3) << s.name << ": the rays must mostly hit";
        // At most 1 in 2,000 rays may part (a ray through a shared edge or vertex, where the
        // two triangle tests round differently), and ties at most 1 in 100.
        EXPECT_LE(c.differ, kRays / 2000) << s.name << ": " << c.first_difference;
        EXPECT_LE(c.ties, kRays / 100) << s.name;
        EXPECT_LE(c.any_wrong, c.differ + c.ties) << s.name;
        EXPECT_EQ(c.incomplete, 0u) << s.name;
    }
}

// The structures' builds and a render through them under VK_LAYER_KHRONOS_validation: no
// message.
TEST(RayQuery, BuildAndTraceUnderValidationWithoutMessages) {
    setenv("MCPT_VULKAN_VALIDATION", "1", 1);
    std::unique_ptr<Backend> backend;
    try {
        backend = test::test_backend("vulkan");
    } catch (const Error& e) {
        unsetenv("MCPT_VULKAN_VALIDATION");
        if (std::strstr(e.what(), "not installed")) GTEST_SKIP() << e.what();
        throw;
    }
    unsetenv("MCPT_VULKAN_VALIDATION");
    if (!backend->device().ray_queries) {
        if (ray_queries_expected()) FAIL() << backend->description() << " has no ray queries";
        GTEST_SKIP() << backend->description() << " has no ray queries";
    }
    auto* vk = dynamic_cast<VulkanBackend*>(backend.get());
    ASSERT_NE(vk, nullptr);
    for (const NamedScene& s : oracle_scenes()) {
        const GpuScene g =
            prepare_scene(s.scene, backend->device(), tree_options("rayquery"), 1024, 1);
        const DeviceCast d = cast_on_device(*backend, g, 1024);
        EXPECT_EQ(d.closest.size(), 1024u);
        RenderOptions o;
        o.width = o.height = 16;
        o.spp = 2;
        const RenderResult r = render(*backend, g, s.scene.camera, o);
        EXPECT_GT(r.mean_radiance(), 0) << s.name;
        EXPECT_EQ(vk->validation_messages(), 0u) << s.name << ": see the messages on stderr";
    }
}

// Planted faults: the triangle the most rays hit first left out of the structure; every
// sphere's box half its size. The oracle sees both.
TEST(RayQuery, OracleCatchesADroppedTriangleAndShrunkSphereBoxes) {
    VULKAN_WITH_RAY_QUERIES(probe, BackendOptions{});
    const Scene scene = oracle_scenes()[0].scene;  // cornell: walls and two spheres
    const GpuScene g =
        prepare_scene(scene, probe->device(), tree_options("rayquery"), int(kRays), 1);
    // The triangle hit first most often (brute force).
    std::vector<uint32_t> first_hits(g.triangles.size());
    for (uint32_t i = 0; i < kRays; ++i) {
        const gpu::Hit h = cpu_trace(g, cpu_cast_ray(g, i), false);
        if (h.prim != NO_HIT && (h.prim & SPHERE_BIT) == 0u) first_hits[h.prim] += 1;
    }
    const uint32_t most =
        uint32_t(std::max_element(first_hits.begin(), first_hits.end()) - first_hits.begin());
    for (const std::string& fault : {"drop:" + std::to_string(most), std::string("shrink")}) {
        BackendOptions o;
        o.accel_fault = fault;
        auto faulty = test::test_backend("vulkan", o);
        const OracleCounts c = check_against_brute_force(g, cast_on_device(*faulty, g, kRays));
        std::printf("fault %s: %u differ (the test allows %u)\n", fault.c_str(), c.differ,
                    kRays / 2000);
        EXPECT_GT(c.differ, kRays / 2000) << fault << ": the oracle must see the fault";
    }
}

// auto keeps the BVH (or no tree) where ray queries are there, and says so.
TEST(RayQuery, AutoNamesThemAndKeepsTheBvh) {
    VULKAN_WITH_RAY_QUERIES(backend, BackendOptions{});
    const GpuScene g =
        prepare_scene(make_builtin_scene("cornell"), backend->device(), tree_options("auto"), 8, 8);
    EXPECT_NE(g.tree_kind, TreeKind::RayQuery);
    EXPECT_NE(g.tree_choice.find("ray queries not picked"), std::string::npos) << g.tree_choice;
}

// A: scene `a` on the BVH; B: scene `b` (the same, or it moved) through ray queries, its
// lights scaled by b_light_scale; same device, independent seeds.
Agreement bvh_against_ray_queries(const Scene& a, const Scene& b, float b_light_scale = 1.f) {
    auto device = test::test_backend("vulkan");
    RenderOptions o;
    o.width = o.height = 32;
    o.max_depth = a.max_depth_hint > 0 ? uint32_t(a.max_depth_hint) : 8u;
    BatchOptions bo;
    bo.batches = 24;
    bo.spp_per_batch = 8;
    bo.seed_base = 100;
    const GpuScene ga = prepare_scene(a, device->device(), tree_options("bvh"), 32, 32);
    const BatchSet sa = render_batches(*device, ga, a.camera, o, bo);
    const GpuScene gb = prepare_scene(b, device->device(), tree_options("rayquery"), 32, 32);
    o.light_scale = b_light_scale;
    bo.seed_base = 5000;
    const BatchSet sb = render_batches(*device, gb, b.camera, o, bo);
    const Agreement g = test_agreement(sa, sb, 0.01);
    std::printf("%s\n", g.verdict().c_str());
    return g;
}

TEST(RayQuery, ImagesAgreeWithTheBvh) {
    VULKAN_WITH_RAY_QUERIES(probe, BackendOptions{});
    Scene lamps = load_gltf(std::string(MCPT_TEST_DATA_DIR) + "/textured.glb");
    for (const NamedScene& s :
         {NamedScene{"cornell", make_builtin_scene("cornell")}, NamedScene{"textured", lamps}}) {
        Scene scene = s.scene;
        validate_scene(scene);
        const Agreement g = bvh_against_ray_queries(scene, scene);
        EXPECT_TRUE(g.agree) << s.name << ": " << g.verdict();
    }
    // Control: a light 2% brighter through ray queries is rejected.
    Scene cornell = make_builtin_scene("cornell");
    validate_scene(cornell);
    const Agreement control = bvh_against_ray_queries(cornell, cornell, 1.02f);
    EXPECT_FALSE(control.agree) << "control: " << control.verdict();
}

// The furnace (every surface, the sphere included, emits 1 and reflects half: L = 2 exactly,
// paths unbounded) through ray queries: no leak through the enclosure, no self-hit on the
// sphere; control: a light 2% brighter is seen.
TEST(RayQuery, FurnaceIsExact) {
    VULKAN_WITH_RAY_QUERIES(device, BackendOptions{});
    Scene furnace = make_furnace_scene(0.5f, 1.0f);
    validate_scene(furnace);
    const GpuScene g = prepare_scene(furnace, device->device(), tree_options("rayquery"), 32, 32);
    const double exact = 2.0, z_limit = 4.5;
    RenderOptions o;
    o.width = o.height = 32;
    o.spp = 256;
    o.seed = 7;
    o.max_depth = uint32_t(furnace.max_depth_hint);
    const test::MeanEstimate e = test::pooled_mean(render(*device, g, furnace.camera, o));
    EXPECT_LT(std::abs(e.z(exact)), z_limit) << "mean " << e.mean << " std error " << e.std_error;
    EXPECT_LT(e.std_error / exact, 0.02 / (2 * z_limit));
    o.light_scale = 1.02f;
    const test::MeanEstimate bright = test::pooled_mean(render(*device, g, furnace.camera, o));
    EXPECT_GT(bright.z(exact), z_limit) << "a 2% brighter light went unnoticed";
}

// Self-intersection at every scale and position the stability suite covers: a scene of
// oriented triangles (the textured scene: walls at angles, cut-outs) moved and scaled, traced
// through ray queries, against the BVH's image of the unit scene.
struct Placement {
    double scale, offset;
};
class RayQueryPlacement : public ::testing::TestWithParam<Placement> {};

TEST_P(RayQueryPlacement, ImageUnchanged) {
    VULKAN_WITH_RAY_QUERIES(device, BackendOptions{});
    const Placement pl = GetParam();
    Scene unit = load_gltf(std::string(MCPT_TEST_DATA_DIR) + "/textured.glb");
    Scene moved = test::transform_scene(unit, pl.scale,
                                        glm::dvec3(pl.offset, -0.5 * pl.offset, 0.25 * pl.offset));
    validate_scene(unit);
    validate_scene(moved);
    const Agreement g = bvh_against_ray_queries(unit, moved);
    EXPECT_TRUE(g.agree) << "scale " << pl.scale << " offset " << pl.offset << ": " << g.verdict();
}

INSTANTIATE_TEST_SUITE_P(Placements, RayQueryPlacement,
                         ::testing::Values(Placement{1e-3, 0}, Placement{1e4, 0}, Placement{1, 1e3},
                                           Placement{1e-3, 1e-1}, Placement{1e4, 1e5}),
                         [](const auto& info) {
                             char buf[64];
                             std::snprintf(buf, sizeof buf, "Scale%gOffset%g", info.param.scale,
                                           info.param.offset);
                             std::string s(buf);
                             for (char& c : s)
                                 if (!isalnum(static_cast<unsigned char>(c))) c = '_';
                             return s;
                         });

// `mcpt compare` A/Bs trace modes on one device through per-side options.
TEST(RayQuery, CompareTakesATraceModePerSide) {
    VULKAN_WITH_RAY_QUERIES(probe, BackendOptions{});
    const std::string args =
        "compare cornell --width 24 --height 16 --batches 16 --spp 8 --a vulkan,tree=bvh --b "
        "vulkan,tree=rayquery";
    const test::CliRun same = test::run_mcpt(args);
    EXPECT_EQ(same.status, 0) << same.output;
    EXPECT_NE(same.output.find("rayquery"), std::string::npos) << same.output;
    const test::CliRun brighter = test::run_mcpt(args + " --b-light-scale 1.05");
    EXPECT_EQ(brighter.status, 2) << brighter.output;
}

// --reproducible through ray queries: the driver's traversal is deterministic, so the file is
// the same bit for bit from one device or from two splitting the samples into chunks (not the
// BVH's file: the driver's triangle test rounds otherwise).
TEST(RayQuery, ReproducibleIsOneFileOnOneOrTwoDevices) {
    VULKAN_WITH_RAY_QUERIES(probe, BackendOptions{});
    const std::string dir = ::testing::TempDir();
    const std::string job =
        "render cornell --tree rayquery --width 48 --height 32 -q --spp 64 "
        "--chunk-seconds 0.05 --reproducible --device vulkan:0";
    const test::CliRun one = test::run_mcpt(job + " -o " + dir + "/rq_one.exr");
    ASSERT_EQ(one.status, 0) << one.output;
    const std::string bytes = test::read_file(dir + "/rq_one.exr");
    // Two devices taking chunks as they come (however the run splits them).
    const test::CliRun two = test::run_mcpt(job + " --device vulkan:0 -o " + dir + "/rq_two.exr");
    ASSERT_EQ(two.status, 0) << two.output;
    EXPECT_TRUE(test::same_bytes(dir + "/rq_two.exr", bytes)) << two.output;
    // A fixed split: halves of the samples rendered apart and merged.
    std::string parts;
    for (int i = 1; i <= 2; ++i) {
        const std::string part = dir + "/rq_part" + std::to_string(i) + ".ckpt";
        std::remove(part.c_str());
        const test::CliRun r =
            test::run_mcpt(job + " --part " + std::to_string(i) + "/2 --checkpoint " + part +
                           " -o " + dir + "/rq_part.png");
        ASSERT_EQ(r.status, 0) << r.output;
        parts += " " + part;
    }
    const test::CliRun m = test::run_mcpt("merge" + parts + " -o " + dir + "/rq_merged.exr");
    ASSERT_EQ(m.status, 0) << m.output;
    EXPECT_TRUE(test::same_bytes(dir + "/rq_merged.exr", bytes)) << m.output;
}

// Debian 12's lavapipe (Mesa 22.3) has no ray queries: asking for them is a clear error,
// and auto never picks them.
TEST(RayQueryAbsent, RayQueryIsAClearErrorAndAutoKeepsTheBvh) {
    auto backend = test::test_backend("vulkan");
    if (backend->device().ray_queries) GTEST_SKIP() << "this Vulkan device has ray queries";
    const std::string out =
        " --width 8 --height 8 --spp 1 -o " + ::testing::TempDir() + "/ray_query_absent.png";
    const test::CliRun r = test::run_mcpt("render cornell --backend vulkan --tree rayquery" + out);
    EXPECT_NE(r.status, 0) << r.output;
    EXPECT_NE(r.output.find("needs a Vulkan device with ray queries"), std::string::npos)
        << r.output;
    const test::CliRun cl =
        test::run_mcpt("render cornell " + test::device_args("opencl") + " --tree rayquery" + out);
    EXPECT_NE(cl.status, 0) << cl.output;
    EXPECT_NE(cl.output.find("OpenCL has none"), std::string::npos) << cl.output;
    const GpuScene g =
        prepare_scene(make_builtin_scene("cornell"), backend->device(), tree_options("auto"), 8, 8);
    EXPECT_NE(g.tree_kind, TreeKind::RayQuery);
}

}  // namespace
}  // namespace mcpt
