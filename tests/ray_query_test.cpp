// The driver's tracing on Vulkan, in both forms: ray queries (--tree rayquery) and the
// ray-tracing pipeline (--tree raypipeline), each against acceleration structures built on
// the device; every test runs for each form the device has. ctest runs the RayQuery suite on
// Mesa 25's lavapipe, which has both (MCPT_TEST_RAY_QUERIES=1: the absence of either fails),
// and the RayQueryAbsent suite on Debian 12's own, which has neither.
//  - The oracle: rays cast one by one on the device (GpuParams.ray_cast) against brute force
//    on the CPU (the same rays, cpu_cast_ray): the same closest triangle or sphere, t and the
//    barycentrics within bounds, or a tie (another primitive the ray meets at that distance,
//    checked by our own test of it); any-hit answers
//    agree with the closest. Planted faults: a triangle left out of the structure, sphere
//    boxes shrunk to half: both caught, in each form.
//  - Images: the BVH and ray queries agree statistically on the device (glass and mirror
//    spheres, a mesh, a textured scene with cut-outs and lamps), and the test rejects a light
//    2% brighter on one side; `mcpt compare` A/Bs the two trace modes by per-side options.
//  - The camera inside the glass and the mirror sphere: light through the glass, none into
//    the closed mirror (control: sphere boxes moved off the spheres let it in).
//  - The furnace exact, the textured scene unchanged at every scale and position, and
//    --reproducible one file from one device, two, or two parts merged.
//  - Without them: --tree rayquery and raypipeline are clear errors, and auto never picks
//    them.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <sstream>

#include "common/accel/cpu_trace.h"
#include "common/analysis/compare.h"
#include "common/error.h"
#include "common/gpu/intersect.h"
#include "common/render/device_registry.h"
#include "common/render/prepare.h"
#include "common/scene/builtin_scenes.h"
#include "common/scene/gltf_loader.h"
#include "test_scenes.h"
#include "test_util.h"
#include "vulkan/vk_accel.h"
#include "vulkan/vk_backend.h"

namespace mcpt {
namespace {

// ctest sets this where the Vulkan driver must have ray queries.
bool ray_queries_expected() {
    const char* e = std::getenv("MCPT_TEST_RAY_QUERIES");
    return e && std::string(e) == "1";
}

// The forms of the driver's tracing that the device has: "rayquery", "raypipeline".
std::vector<std::string> driver_modes(const DeviceInfo& d) {
    std::vector<std::string> m;
    if (d.ray_queries) m.push_back("rayquery");
    if (d.ray_pipelines) m.push_back("raypipeline");
    return m;
}

// The Vulkan device under test, which must have both forms where ray_queries_expected().
#define VULKAN_WITH_RAY_QUERIES(backend, options)                                              \
    auto backend = test::test_backend("vulkan", options);                                      \
    if (driver_modes(backend->device()).size() < (ray_queries_expected() ? 2u : 1u)) {         \
        if (ray_queries_expected())                                                            \
            FAIL() << backend->description() << " lacks ray queries or the pipeline";          \
        GTEST_SKIP() << backend->description() << " has neither ray queries nor the pipeline"; \
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

// The oracle's closest hits for rays 0 .. n-1 (brute force on the CPU).
std::vector<gpu::Hit> brute_force(const GpuScene& g, uint32_t n) {
    std::vector<gpu::Hit> want;
    for (uint32_t i = 0; i < n; ++i) want.push_back(cpu_trace(g, cpu_cast_ray(g, i), false));
    return want;
}

// Whether the device's primitive is there at its t: the ray meets it (our triangle or sphere
// test, without tmax) within close_t of it. A tie must be one.
bool hits_at(const GpuScene& g, gpu::Ray ray, const gpu::Hit& got) {
    ray.tmax = 2.f * got.t + 1.f;
    float t = -1.f;
    if ((got.prim & SPHERE_BIT) != 0u) {
        const uint32_t s = got.prim & ~SPHERE_BIT;
        if (s < g.spheres.size()) t = gpu::intersect_sphere(ray, g.spheres[s]);
    } else if (got.prim < g.triangles.size()) {
        // Grown by 1e-4 about its centroid: a ray through a shared edge may miss the neighbour
        // in our test by a rounding.
        gpu::GpuTriangle tri = g.triangles[got.prim];
        float* v[3][3] = {{&tri.v0x, &tri.v0y, &tri.v0z},
                          {&tri.v1x, &tri.v1y, &tri.v1z},
                          {&tri.v2x, &tri.v2y, &tri.v2z}};
        for (int a = 0; a < 3; ++a) {
            const float mid = (*v[0][a] + *v[1][a] + *v[2][a]) / 3.f;
            for (int k = 0; k < 3; ++k) *v[k][a] = mid + (*v[k][a] - mid) * (1.f + 1e-4f);
        }
        const gpu::TriHit th = gpu::intersect_triangle(ray, gpu::woop_setup(ray.d), tri);
        if (th.hit) t = th.t;
    }
    return t > 0.f && close_t(t, got.t);
}

OracleCounts check_against_brute_force(const GpuScene& g, const std::vector<gpu::Hit>& oracle,
                                       const DeviceCast& d) {
    OracleCounts c;
    for (uint32_t i = 0; i < d.closest.size(); ++i) {
        const gpu::Hit& want = oracle[i];
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
        } else if (got.prim != NO_HIT && want.prim != NO_HIT && close_t(got.t, want.t) &&
                   hits_at(g, cpu_cast_ray(g, i), got)) {
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
        std::vector<gpu::Hit> oracle;
        for (const std::string& mode : driver_modes(backend->device())) {
            const std::string name = s.name + ", " + mode;
            const GpuScene g =
                prepare_scene(s.scene, backend->device(), tree_options(mode), int(kRays), 1);
            ASSERT_NE(g.params.scene_flags & (SCENE_RAY_QUERY | SCENE_RAY_PIPELINE), 0u);
            if (oracle.empty()) oracle = brute_force(g, kRays);
            const OracleCounts c =
                check_against_brute_force(g, oracle, cast_on_device(*backend, g, kRays));
            std::printf(
                "%s: %u rays, %u hits; %u the same, %u ties, %u differ, %u any-hit wrong%s%s\n",
                name.c_str(), c.rays, c.hits, c.same, c.ties, c.differ, c.any_wrong,
                c.differ ? "; the first: " : "", c.first_difference.c_str());
            EXPECT_GT(c.hits, kRays / 3) << name << ": the rays must mostly hit";
            // At most 1 in 2,000 rays may part (a ray through a shared edge or vertex, where the
            // two triangle tests round differently, or a zero-area sliver at a pole that the
            // driver's test meets and ours does not), and ties at most 1 in 100.
            EXPECT_LE(c.differ, kRays / 2000) << name << ": " << c.first_difference;
            EXPECT_LE(c.ties, kRays / 100) << name;
            EXPECT_LE(c.any_wrong, c.differ + c.ties) << name;
            EXPECT_EQ(c.incomplete, 0u) << name;
        }
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
    if (driver_modes(backend->device()).size() < (ray_queries_expected() ? 2u : 1u)) {
        if (ray_queries_expected())
            FAIL() << backend->description() << " lacks ray queries or the pipeline";
        GTEST_SKIP() << backend->description() << " has neither ray queries nor the pipeline";
    }
    auto* vk = dynamic_cast<VulkanBackend*>(backend.get());
    ASSERT_NE(vk, nullptr);
    for (const std::string& mode : driver_modes(backend->device())) {
        for (const NamedScene& s : oracle_scenes()) {
            const GpuScene g =
                prepare_scene(s.scene, backend->device(), tree_options(mode), 1024, 1);
            const DeviceCast d = cast_on_device(*backend, g, 1024);
            EXPECT_EQ(d.closest.size(), 1024u);
            RenderOptions o;
            o.width = o.height = 16;
            o.spp = 2;
            const RenderResult r = render(*backend, g, s.scene.camera, o);
            EXPECT_GT(r.mean_radiance(), 0) << s.name << ", " << mode;
            EXPECT_EQ(vk->validation_messages(), 0u)
                << s.name << ", " << mode << ": see the messages on stderr";
        }
    }
}

// Planted faults: the triangle the most rays hit first left out of the structure; every
// sphere's box half its size. The oracle sees both.
TEST(RayQuery, OracleCatchesADroppedTriangleAndShrunkSphereBoxes) {
    VULKAN_WITH_RAY_QUERIES(probe, BackendOptions{});
    const Scene scene = oracle_scenes()[0].scene;  // cornell: walls and two spheres
    for (const std::string& mode : driver_modes(probe->device())) {
        const GpuScene g = prepare_scene(scene, probe->device(), tree_options(mode), int(kRays), 1);
        const std::vector<gpu::Hit> oracle = brute_force(g, kRays);
        // The triangle hit first most often.
        std::vector<uint32_t> first_hits(g.triangles.size());
        for (const gpu::Hit& h : oracle)
            if (h.prim != NO_HIT && (h.prim & SPHERE_BIT) == 0u) first_hits[h.prim] += 1;
        const uint32_t most =
            uint32_t(std::max_element(first_hits.begin(), first_hits.end()) - first_hits.begin());
        for (const std::string& fault : {"drop:" + std::to_string(most), std::string("shrink")}) {
            BackendOptions o;
            o.accel_fault = fault;
            auto faulty = test::test_backend("vulkan", o);
            const OracleCounts c =
                check_against_brute_force(g, oracle, cast_on_device(*faulty, g, kRays));
            std::printf("%s, fault %s: %u differ (the test allows %u)\n", mode.c_str(),
                        fault.c_str(), c.differ, kRays / 2000);
            EXPECT_GT(c.differ, kRays / 2000)
                << mode << ", " << fault << ": the oracle must see the fault";
        }
    }
}

// Triangles go to the driver in runs of opaque and cut-out ones (only the latter call on the
// shader's cut-out test); too many runs, and one of all.
TEST(DriverTriangleRuns, SplitWhereCutOutsBeginAndEnd) {
    using vk::TriangleRun;
    const auto runs = [](const std::vector<bool>& c) {
        std::string out;
        for (const TriangleRun& r : vk::triangle_runs(c, c.size()))
            out +=
                std::to_string(r.first) + "+" + std::to_string(r.count) + (r.cut_out ? "c " : " ");
        return out;
    };
    EXPECT_EQ(runs({false, false, false}), "0+3 ");
    EXPECT_EQ(runs({true, true}), "0+2c ");
    EXPECT_EQ(runs({false, false, true, false}), "0+2 2+1c 3+1 ");
    std::vector<bool> alternating(2 * vk::kMaxTriangleRuns + 1);
    for (size_t i = 0; i < alternating.size(); i += 2) alternating[i] = true;
    EXPECT_EQ(runs(alternating), "0+" + std::to_string(alternating.size()) + "c ");
    EXPECT_EQ(vk::triangle_runs({}, 2).size(), 1u);  // no materials: opaque
}

// auto keeps the BVH (or no tree) where ray queries are there, and says so.
TEST(RayQuery, AutoNamesThemAndKeepsTheBvh) {
    VULKAN_WITH_RAY_QUERIES(backend, BackendOptions{});
    const GpuScene g =
        prepare_scene(make_builtin_scene("cornell"), backend->device(), tree_options("auto"), 8, 8);
    EXPECT_FALSE(traced_by_driver(g.tree_kind));
    const bool queries = backend->device().ray_queries;
    EXPECT_NE(g.tree_choice.find(queries ? "ray queries not picked"
                                         : "the ray-tracing pipeline not picked"),
              std::string::npos)
        << g.tree_choice;
}

// A: scene `a` on the BVH; B: scene `b` (the same, or it moved) traced by the driver in this
// form, its lights scaled by b_light_scale; same device, independent seeds.
Agreement bvh_against_driver(const std::string& mode, const Scene& a, const Scene& b,
                             float b_light_scale = 1.f) {
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
    const GpuScene gb = prepare_scene(b, device->device(), tree_options(mode), 32, 32);
    o.light_scale = b_light_scale;
    bo.seed_base = 5000;
    const BatchSet sb = render_batches(*device, gb, b.camera, o, bo);
    const Agreement g = test_agreement(sa, sb, 0.01);
    std::printf("%s: %s\n", mode.c_str(), g.verdict().c_str());
    return g;
}

TEST(RayQuery, ImagesAgreeWithTheBvh) {
    VULKAN_WITH_RAY_QUERIES(probe, BackendOptions{});
    Scene lamps = load_gltf(std::string(MCPT_TEST_DATA_DIR) + "/textured.glb");
    Scene cornell = make_builtin_scene("cornell");
    validate_scene(cornell);
    validate_scene(lamps);
    for (const std::string& mode : driver_modes(probe->device())) {
        for (const NamedScene& s :
             {NamedScene{"cornell", cornell}, NamedScene{"textured", lamps}}) {
            const Agreement g = bvh_against_driver(mode, s.scene, s.scene);
            EXPECT_TRUE(g.agree) << s.name << ", " << mode << ": " << g.verdict();
        }
        // Control: a light 2% brighter through the driver is rejected.
        const Agreement control = bvh_against_driver(mode, cornell, cornell, 1.02f);
        EXPECT_FALSE(control.agree) << mode << ", control: " << control.verdict();
    }
}

// The furnace (every surface, the sphere included, emits 1 and reflects half: L = 2 exactly,
// paths unbounded) through ray queries: no leak through the enclosure, no self-hit on the
// sphere; control: a light 2% brighter is seen.
TEST(RayQuery, FurnaceIsExact) {
    VULKAN_WITH_RAY_QUERIES(device, BackendOptions{});
    Scene furnace = make_furnace_scene(0.5f, 1.0f);
    validate_scene(furnace);
    for (const std::string& mode : driver_modes(device->device())) {
        const GpuScene g = prepare_scene(furnace, device->device(), tree_options(mode), 32, 32);
        const double exact = 2.0, z_limit = 4.5;
        RenderOptions o;
        o.width = o.height = 32;
        o.spp = 256;
        o.seed = 7;
        o.max_depth = uint32_t(furnace.max_depth_hint);
        const test::MeanEstimate e = test::pooled_mean(render(*device, g, furnace.camera, o));
        EXPECT_LT(std::abs(e.z(exact)), z_limit)
            << mode << ": mean " << e.mean << " std error " << e.std_error;
        EXPECT_LT(e.std_error / exact, 0.02 / (2 * z_limit));
        o.light_scale = 1.02f;
        const test::MeanEstimate bright = test::pooled_mean(render(*device, g, furnace.camera, o));
        EXPECT_GT(bright.z(exact), z_limit) << mode << ": a 2% brighter light went unnoticed";
    }
}

// The camera inside the glass sphere and inside the mirror sphere (the stability suite's
// AwkwardCamera.InsideGeometry) through the driver: every path starts inside a sphere the
// driver meets only through our intersection test, bounce after bounce from its inside; no
// invalid sample, light through the glass, and exactly none inside the closed mirror.
TEST(RayQuery, InsideSpheresNothingLeaks) {
    VULKAN_WITH_RAY_QUERIES(device, BackendOptions{});
    // Control: the sphere boxes moved by 1.5 radii along +z, so that the camera's
    // rays from the mirror's centre (toward -z) meet no box, leave the mirror and bring light
    // in.
    BackendOptions shifted;
    shifted.accel_fault = "shift";
    auto faulty = test::test_backend("vulkan", shifted);
    for (const std::string& mode : driver_modes(device->device())) {
        for (int s = 0; s < 2; ++s) {
            Scene scene = make_builtin_scene("cornell");
            scene.camera.position = scene.spheres[size_t(s)].center;
            validate_scene(scene);
            const GpuScene g = prepare_scene(scene, device->device(), tree_options(mode), 32, 32);
            RenderOptions o;
            o.width = o.height = 32;
            o.spp = 64;
            const RenderResult r = render(*device, g, scene.camera, o);
            EXPECT_EQ(r.nonfinite_total, 0u) << mode << ", sphere " << s;
            if (s == 0) {
                EXPECT_GT(r.mean_radiance(), 0.0) << mode << ": the glass sphere lets light in";
            } else {
                EXPECT_EQ(r.mean_radiance(), 0.0) << mode << ": light leaked into the mirror";
                const RenderResult leak = render(*faulty, g, scene.camera, o);
                EXPECT_GT(leak.mean_radiance(), 0.0) << mode << ": control: the shifted boxes";
            }
        }
    }
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
    for (const std::string& mode : driver_modes(device->device())) {
        const Agreement g = bvh_against_driver(mode, unit, moved);
        EXPECT_TRUE(g.agree) << mode << ", scale " << pl.scale << " offset " << pl.offset << ": "
                             << g.verdict();
    }
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
    for (const std::string& mode : driver_modes(probe->device())) {
        const std::string args =
            "compare cornell --width 24 --height 16 --batches 16 --spp 8 --a vulkan,tree=bvh --b "
            "vulkan,tree=" +
            mode;
        const test::CliRun same = test::run_mcpt(args);
        EXPECT_EQ(same.status, 0) << same.output;
        EXPECT_NE(same.output.find(mode), std::string::npos) << same.output;
        const test::CliRun brighter = test::run_mcpt(args + " --b-light-scale 1.05");
        EXPECT_EQ(brighter.status, 2) << brighter.output;
    }
}

// bench --throughput rows for the driver's forms on Vulkan (none on OpenCL, with a note), with
// the driver's build time and the bytes of its structures per triangle.
TEST(RayQuery, BenchRowsNameTheDriversStructures) {
    VULKAN_WITH_RAY_QUERIES(probe, BackendOptions{});
    const std::string dir = ::testing::TempDir() + "/rq_bench";
    std::filesystem::create_directories(dir + "/no-models");
    std::string trees = "bvh";
    for (const std::string& mode : driver_modes(probe->device())) trees += "," + mode;
    const test::CliRun r = test::run_mcpt(
        "bench --throughput --quick --time 0.2 --width 32 --height 32 --tree " + trees +
        " --models " + dir + "/no-models --backend opencl:" + test::test_opencl_device() +
        " --backend vulkan:0 -o " + dir + "/tp");
    ASSERT_EQ(r.status, 0) << r.output;
    for (const std::string& mode : driver_modes(probe->device())) {
        EXPECT_NE(r.output.find("no " + mode + " here: no rows"), std::string::npos) << r.output;
        // Each scene's row: the driver's build time and bytes per triangle filled in.
        size_t rows = 0;
        for (size_t at = r.output.find("| " + mode + " | vulkan: "); at != std::string::npos;
             at = r.output.find("| " + mode + " | vulkan: ", at + 1)) {
            const std::string line = r.output.substr(at, r.output.find('\n', at) - at);
            std::vector<std::string> cells;
            std::istringstream in(line);
            for (std::string c; std::getline(in, c, '|');) cells.push_back(c);
            ASSERT_GE(cells.size(), 2u) << line;
            const double bytes = std::stod(cells[cells.size() - 1]);
            const double build_ms = std::stod(cells[cells.size() - 2]);
            EXPECT_GT(build_ms, 0.0) << line;
            EXPECT_GT(bytes, 0.0) << line;
            EXPECT_NE(line.find("driver's"), std::string::npos) << line;
            rows += 1;
        }
        EXPECT_EQ(rows, 2u) << mode << ": a row per scene\n" << r.output;
    }
}

// --reproducible through ray queries: the driver's traversal is deterministic, so the file is
// the same bit for bit from one device or from two splitting the samples into chunks (not the
// BVH's file: the driver's triangle test rounds otherwise).
TEST(RayQuery, ReproducibleIsOneFileOnOneOrTwoDevices) {
    VULKAN_WITH_RAY_QUERIES(probe, BackendOptions{});
    const std::string dir = ::testing::TempDir();
    for (const std::string& mode : driver_modes(probe->device())) {
        const std::string job = "render cornell --tree " + mode +
                                " --width 48 --height 32 -q --spp 64 "
                                "--chunk-seconds 0.05 --reproducible --device vulkan:0";
        const std::string stem = dir + "/" + mode;
        const test::CliRun one = test::run_mcpt(job + " -o " + stem + "_one.exr");
        ASSERT_EQ(one.status, 0) << one.output;
        const std::string bytes = test::read_file(stem + "_one.exr");
        // Two devices taking chunks as they come (however the run splits them).
        const test::CliRun two = test::run_mcpt(job + " --device vulkan:0 -o " + stem + "_two.exr");
        ASSERT_EQ(two.status, 0) << two.output;
        EXPECT_TRUE(test::same_bytes(stem + "_two.exr", bytes)) << mode << ": " << two.output;
        // A fixed split: halves of the samples rendered apart and merged.
        std::string parts;
        for (int i = 1; i <= 2; ++i) {
            const std::string part = stem + "_part" + std::to_string(i) + ".ckpt";
            std::remove(part.c_str());
            const test::CliRun r =
                test::run_mcpt(job + " --part " + std::to_string(i) + "/2 --checkpoint " + part +
                               " -o " + stem + "_part.png");
            ASSERT_EQ(r.status, 0) << r.output;
            parts += " " + part;
        }
        const test::CliRun m = test::run_mcpt("merge" + parts + " -o " + stem + "_merged.exr");
        ASSERT_EQ(m.status, 0) << m.output;
        EXPECT_TRUE(test::same_bytes(stem + "_merged.exr", bytes)) << mode << ": " << m.output;
    }
}

// Debian 12's lavapipe (Mesa 22.3) has neither ray queries nor the pipeline: asking for either
// is a clear error, and auto never picks them.
TEST(RayQueryAbsent, RayQueryIsAClearErrorAndAutoKeepsTheBvh) {
    auto backend = test::test_backend("vulkan");
    if (!driver_modes(backend->device()).empty())
        GTEST_SKIP() << "this Vulkan device has ray queries or the pipeline";
    const std::string out =
        " --width 8 --height 8 --spp 1 -o " + ::testing::TempDir() + "/ray_query_absent.png";
    const test::CliRun r = test::run_mcpt("render cornell --backend vulkan --tree rayquery" + out);
    EXPECT_NE(r.status, 0) << r.output;
    EXPECT_NE(r.output.find("needs a Vulkan device with ray queries"), std::string::npos)
        << r.output;
    const test::CliRun p =
        test::run_mcpt("render cornell --backend vulkan --tree raypipeline" + out);
    EXPECT_NE(p.status, 0) << p.output;
    EXPECT_NE(p.output.find("needs a Vulkan device with the ray-tracing pipeline"),
              std::string::npos)
        << p.output;
    for (const char* mode : {"rayquery", "raypipeline"}) {
        const test::CliRun cl = test::run_mcpt("render cornell " + test::device_args("opencl") +
                                               " --tree " + mode + out);
        EXPECT_NE(cl.status, 0) << cl.output;
        EXPECT_NE(cl.output.find("OpenCL has none"), std::string::npos) << cl.output;
    }
    const GpuScene g =
        prepare_scene(make_builtin_scene("cornell"), backend->device(), tree_options("auto"), 8, 8);
    EXPECT_FALSE(traced_by_driver(g.tree_kind));
}

}  // namespace
}  // namespace mcpt
