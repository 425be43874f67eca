// The light tree (common/render/light_tree.h, common/gpu/light_tree.h): at shading points of a
// scene of many small emitters and lamps, the device code's pick (compiled for the CPU) against
// its pmf by chi-square, the pmf summed over every light is 1, a light's pmf by its trail is
// the pick's; and renders with the tree exact where the lights' radiance is known.
#include "common/gpu/light_tree.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <functional>
#include <random>

#include "app/commands.h"
#include "common/accel/kdtree.h"
#include "common/analysis/stats.h"
#include "common/error.h"
#include "common/render/gpu_scene.h"
#include "common/render/light_tree.h"
#include "light_cases.h"
#include "test_util.h"

namespace mcpt {
namespace {

// A level emissive quad (two triangles) of 0.2 m centred at c, of radiance `power`, facing down
// or up.
void add_emissive_quad(Scene& scene, glm::vec3 c, float power, bool facing_up) {
    Material m;
    m.color = glm::vec3(0.f);
    m.emission = glm::vec3(power);
    const uint32_t mat = scene.add_material(m);
    const glm::vec3 a = c + glm::vec3(-0.1f, 0, -0.1f), b = c + glm::vec3(0.1f, 0, -0.1f),
                    d = c + glm::vec3(0.1f, 0, 0.1f), e = c + glm::vec3(-0.1f, 0, 0.1f);
    if (facing_up) {
        scene.triangles.push_back({a, d, b, mat});
        scene.triangles.push_back({a, e, d, mat});
    } else {
        scene.triangles.push_back({a, b, d, mat});
        scene.triangles.push_back({a, d, e, mat});
    }
}

// A floor plan of n emissive quads (two triangles each) of different powers and a few lamps.
Scene many_lights(int n, uint32_t seed) {
    Scene scene = test::plane_scene(0.5f, 10.f, 1.f);
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> pos(-9.f, 9.f), power(0.2f, 5.f);
    for (int i = 0; i < n; ++i) {
        const float p = power(rng);
        const glm::vec3 c(pos(rng), 0.5f, pos(rng));
        add_emissive_quad(scene, c, p, false);
    }
    for (int i = 0; i < n; ++i) {  // as many small lamps, low over the floor
        PunctualLight l;
        l.kind = PunctualKind::Point;
        l.position = glm::vec3(pos(rng), 0.3f, pos(rng));
        l.intensity = glm::vec3(0.02f * power(rng));
        scene.punctual_lights.push_back(l);
    }
    scene.light_tree = true;
    return scene;
}

uint32_t float_word(float f) {
    uint32_t w;
    std::memcpy(&w, &f, 4);
    return w;
}
float word_float(uint32_t w) {
    float f;
    std::memcpy(&f, &w, 4);
    return f;
}

// The angle between vectors (atan2 of the cross and dot products: exact near 0 and pi, where
// acos of a dot product is not).
double angle_between(const glm::vec3& a, const glm::vec3& b) {
    const glm::dvec3 da(a), db(b);
    return std::atan2(glm::length(glm::cross(da, db)), glm::dot(da, db));
}

// Cone `outer` holds cone `inner`: every direction within inner is within outer.
bool holds(const DirectionCone& outer, const DirectionCone& inner) {
    if (outer.cos_theta <= -1.f) return true;
    if (inner.cos_theta <= -1.f) return false;
    return angle_between(outer.axis, inner.axis) + std::acos(double(inner.cos_theta)) <=
           std::acos(double(outer.cos_theta)) + 1e-6;
}

// Random cones: half of them narrow (emitters, spots), some every way.
DirectionCone random_cone(std::mt19937& rng) {
    std::normal_distribution<float> g;
    std::uniform_real_distribution<float> u(0.f, 1.f);
    DirectionCone c;
    c.axis = glm::normalize(glm::vec3(g(rng), g(rng), g(rng)));
    const float r = u(rng);
    c.cos_theta = r < 0.1f ? -1.f : r < 0.5f ? 1.f : std::cos(3.1f * u(rng));
    return c;
}

// The union of two cones holds both, over random pairs; a cone that leaves one out is caught.
TEST(LightTree, ConeUnionHoldsBoth) {
    std::mt19937 rng(4);
    int a_alone_misses_b = 0;
    for (int k = 0; k < 20000; ++k) {
        const DirectionCone a = random_cone(rng), b = random_cone(rng);
        const DirectionCone u = cone_union(a, b);
        ASSERT_TRUE(holds(u, a) && holds(u, b))
            << k << ": " << a.cos_theta << ", " << b.cos_theta << " -> " << u.cos_theta;
        // The control: a "union" that kept a alone would fail for these.
        a_alone_misses_b += !holds(a, b);
    }
    EXPECT_GT(a_alone_misses_b, 10000);
    const DirectionCone up{{0.f, 1.f, 0.f}, 1.f}, down{{0.f, -1.f, 0.f}, 1.f};
    EXPECT_FALSE(holds(up, down));
    EXPECT_TRUE(holds(cone_union(up, down), down));
}

// Every node's cone holds the cones of all lights below it (lights of random cones).
TEST(LightTree, NodeConesHoldTheirLights) {
    std::mt19937 rng(6);
    std::uniform_real_distribution<float> pos(-5.f, 5.f);
    std::vector<TreeLight> lights;
    for (uint32_t i = 0; i < 500; ++i) {
        TreeLight l;
        l.lo = glm::vec3(pos(rng), pos(rng), pos(rng));
        l.hi = l.lo + glm::vec3(0.1f);
        l.power = 1.0 + i % 7;
        l.slot = i;
        const DirectionCone c = random_cone(rng);
        l.axis = c.axis, l.cos_o = c.cos_theta;
        lights.push_back(l);
    }
    const LightTree tree = build_light_tree(lights);
    // The lights under each node, gathered from the leaves up; each checked against the node.
    size_t checked = 0;
    const std::function<std::vector<uint32_t>(uint32_t)> under = [&](uint32_t i) {
        const gpu::GpuLightTreeNode& n = tree.nodes[i];
        std::vector<uint32_t> slots;
        if (n.child & LIGHT_TREE_LEAF) {
            slots.push_back(n.child & ~LIGHT_TREE_LEAF);
        } else {
            slots = under(n.child);
            const std::vector<uint32_t> second = under(n.child + 1);
            slots.insert(slots.end(), second.begin(), second.end());
        }
        const DirectionCone cone{{n.axis_x, n.axis_y, n.axis_z}, n.cos_o};
        for (uint32_t s : slots) {
            EXPECT_TRUE(holds(cone, {lights[s].axis, lights[s].cos_o})) << "node " << i;
            ++checked;
        }
        return slots;
    };
    EXPECT_EQ(under(0).size(), lights.size());
    EXPECT_GT(checked, lights.size() * 5);
}

#define TREE_ARGS                                                                      \
    &g.params, nullptr, nullptr, nullptr, nullptr, nullptr, nullptr, nullptr, nullptr, \
        g.texels.data(),

TEST(LightTree, PicksFollowTheirPmfAndSumToOne) {
    const Scene scene = many_lights(100, 3);
    const GpuScene g = pack_scene(scene, build_kdtree(scene.triangles, TreeOptions{}));
    // 100 rectangles (one light each, for two triangles) and 100 lamps; each rectangle's
    // other half found in the trails with its head's trail.
    ASSERT_EQ(g.params.num_tree_lights, 200u);
    ASSERT_EQ(g.lights.size(), 200u);
    ASSERT_EQ(g.params.num_light_trails, 300u);
    ASSERT_EQ(scene.triangles.size(), 202u);
    for (uint32_t head = 2; head < 202; head += 2)  // triangles 0 and 1 are the floor
        EXPECT_EQ(gpu::light_tree_trail(TREE_ARGS head + 1), gpu::light_tree_trail(TREE_ARGS head));
    std::mt19937 rng(9);
    std::uniform_real_distribution<float> u01(0.f, 1.f), pos(-10.f, 10.f);
    // Receivers without a normal, facing up, tilted.
    const glm::vec3 normals[4] = {glm::vec3(0.f), glm::vec3(0.f, 1.f, 0.f),
                                  glm::normalize(glm::vec3(1.f, 1.f, 0.f)), glm::vec3(0.f)};
    for (int k = 0; k < 4; ++k) {
        const glm::vec3 x(pos(rng), 0.f, pos(rng)), rn = normals[k];
        // pmf of every light by its trail; their sum.
        std::vector<double> expected(g.lights.size(), 0.0);
        double sum = 0;
        for (size_t slot = 0; slot < g.lights.size(); ++slot) {
            const uint32_t trail = gpu::light_tree_trail(TREE_ARGS g.lights[slot].prim);
            ASSERT_NE(trail, NO_HIT) << slot;
            expected[slot] = gpu::light_tree_pmf(TREE_ARGS x, rn, trail);
            ASSERT_GT(expected[slot], 0.0) << slot;
            sum += expected[slot];
        }
        EXPECT_NEAR(sum, 1.0, 1e-5) << "at " << x.x << ", " << x.z;
        // Picks against it; each pick's pmf is its light's.
        constexpr int kPicks = 200000;
        std::vector<double> observed(g.lights.size(), 0.0);
        for (int i = 0; i < kPicks; ++i) {
            const gpu::TreePick p = gpu::light_tree_pick(TREE_ARGS x, rn, u01(rng));
            ASSERT_LT(p.slot, g.lights.size());
            ASSERT_FLOAT_EQ(p.pmf, float(expected[p.slot]));
            observed[p.slot] += 1;
        }
        for (double& e : expected) e *= kPicks;
        const double p_value = stats::chi_square_test(observed, expected);
        std::printf(
            "light tree at (%.1f, %.1f), normal (%.2f, %.2f, %.2f): sum of pmf %.6f, "
            "chi-square p = %.3f\n",
            x.x, x.z, rn.x, rn.y, rn.z, sum, p_value);
        EXPECT_GT(p_value, 1e-3);
    }
}

// Mean over pixels of one sample's variance (channel 0).
double sample_variance(const RenderResult& r) {
    double v = 0;
    for (size_t i = 0; i < r.nonfinite.size(); ++i) {
        const double n = double(r.spp), mean = r.sum[3 * i] / n;
        v += std::max(0.0, r.sum_sq[3 * i] / n - mean * mean) * n / (n - 1);
    }
    return v / double(r.nonfinite.size());
}

// Lights on two storeys: n a metre below the floor (y = 0), n a metre above it; point lamps,
// or emissive quads facing the floor (those below hidden by it).
Scene two_storeys(int n, uint32_t seed, bool quads) {
    Scene scene = test::plane_scene(0.5f, 10.f, 1.f);
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> pos(-9.f, 9.f), power(0.2f, 5.f);
    for (int i = 0; i < 2 * n; ++i) {
        const float y = i < n ? -1.f : 1.f;
        if (quads) {
            const float p = power(rng);
            const glm::vec3 c(pos(rng), y, pos(rng));
            add_emissive_quad(scene, c, p, i < n);
            continue;
        }
        PunctualLight l;
        l.kind = PunctualKind::Point;
        l.position = glm::vec3(pos(rng), y, pos(rng));
        l.intensity = glm::vec3(power(rng));
        scene.punctual_lights.push_back(l);
    }
    scene.light_tree = true;
    // Each triangle a light of its own (the thresholds below were set so; the tree over
    // rectangles is tested by LightTree.PicksFollowTheirPmfAndSumToOne and SeveralLights).
    scene.triangle_light_sampling = Scene::TriangleLightSampling::Triangles;
    return scene;
}

// The share of the tree's picks at points of the floor (normal rn) that go to lamps below it.
double share_below(const Scene& scene, const GpuScene& g, glm::vec3 rn) {
    std::mt19937 rng(3);
    std::uniform_real_distribution<float> pos(-8.f, 8.f);
    double below = 0;
    for (int k = 0; k < 16; ++k) {
        const glm::vec3 x(pos(rng), 0.f, pos(rng));
        for (const gpu::GpuLight& l : g.lights)
            if (scene.punctual_lights.at(l.prim & LIGHT_INDEX_MASK).position.y < 0.f)
                below +=
                    gpu::light_tree_pmf(TREE_ARGS x, rn, gpu::light_tree_trail(TREE_ARGS l.prim));
    }
    return below / 16;
}

// The receiver's normal: lamps below a receiver facing up get almost none of its picks (those
// left share a node with lamps above); without the normal they get about half; the normal turned
// down gives them nearly all (the control: the share follows the normal, not the lights).
TEST(LightTree, ReceiverNormalLeavesLightsBelow) {
    const Scene scene = two_storeys(100, 5, false);
    const GpuScene g = pack_scene(scene, build_kdtree(scene.triangles, TreeOptions{}));
    const double up = share_below(scene, g, glm::vec3(0.f, 1.f, 0.f)),
                 none = share_below(scene, g, glm::vec3(0.f)),
                 down = share_below(scene, g, glm::vec3(0.f, -1.f, 0.f));
    std::printf(
        "share of the picks to lamps below: facing up %.4f, no normal %.4f, facing down "
        "%.4f\n",
        up, none, down);
    EXPECT_LT(up, 0.05);
    EXPECT_GT(none, 0.2);
    EXPECT_GT(down, 0.95);
}

// Normals through the path's two floats: decoded, each within 1e-6 of the normal; no normal
// stays none.
TEST(LightTree, ReceiverNormalSurvivesItsEncoding) {
    std::mt19937 rng(4);
    std::normal_distribution<float> g01;
    float worst = 0.f;
    for (int i = 0; i < 100000; ++i) {
        const glm::vec3 n = glm::normalize(glm::vec3(g01(rng), g01(rng), g01(rng)));
        worst = std::max(worst, glm::length(gpu::receiver_decode(gpu::receiver_encode(n)) - n));
    }
    for (const glm::vec3 axis :
         {glm::vec3(0, 0, 1), glm::vec3(0, 0, -1), glm::vec3(1, 0, 0), glm::vec3(0, -1, 0)})
        worst =
            std::max(worst, glm::length(gpu::receiver_decode(gpu::receiver_encode(axis)) - axis));
    EXPECT_LT(worst, 1e-6f);
    EXPECT_EQ(gpu::receiver_decode(glm::vec2(4.f, 0.f)), glm::vec3(0.f));  // NO_RECEIVER
}

class LightTreeRender : public ::testing::TestWithParam<std::string> {};

// Many lights over a floor plan: the tree's pick beats power alone per sample by at least
// 2x (the same image in expectation: the means agree).
TEST_P(LightTreeRender, ManyLightsBeatPowerAlonePerSample) {
    Scene scene = many_lights(200, 5);
    test::CaseRender how;
    how.spp = 64;
    const RenderResult tree = test::render_case(GetParam(), scene, 32, how);
    scene.light_tree = false;
    const RenderResult power = test::render_case(GetParam(), scene, 32, how);
    const double vt = sample_variance(tree), vp = sample_variance(power);
    const test::MeanEstimate mt = test::pooled_mean(tree), mp = test::pooled_mean(power);
    std::printf(
        "%s, 200 quads and 200 lamps: variance per sample, power %.4g, tree %.4g: %.2fx; "
        "means %.5f and %.5f (z %.2f)\n",
        GetParam().c_str(), vp, vt, vp / vt, mp.mean, mt.mean,
        (mt.mean - mp.mean) / std::hypot(mt.std_error, mp.std_error));
    EXPECT_GT(vp / vt, 2.0);
    EXPECT_LT(std::abs(mt.mean - mp.mean) / std::hypot(mt.std_error, mp.std_error), 4.5);
}

// many_lights()'s quads over the floor facing it, no lamps, and beside the floor a wall of as
// many quads ten times as bright, facing away from it (+x), out of the camera's view.
Scene quads_and_a_bank_facing_away(int n, uint32_t seed) {
    Scene scene = many_lights(n, seed);
    scene.punctual_lights.clear();
    std::mt19937 rng(seed + 1);
    std::uniform_real_distribution<float> y(1.f, 10.f), z(-9.f, 9.f), power(2.f, 50.f);
    for (int i = 0; i < n; ++i) {
        Material m;
        m.color = glm::vec3(0.f);
        m.emission = glm::vec3(power(rng));
        const uint32_t mat = scene.add_material(m);
        const glm::vec3 c(30.f, y(rng), z(rng));
        const glm::vec3 a = c + glm::vec3(0, -0.1f, -0.1f), b = c + glm::vec3(0, 0.1f, -0.1f),
                        d = c + glm::vec3(0, 0.1f, 0.1f), e = c + glm::vec3(0, -0.1f, 0.1f);
        scene.triangles.push_back({a, b, d, mat});  // facing +x
        scene.triangles.push_back({a, d, e, mat});
    }
    return scene;
}

// The share of the tree's picks that go to the wall (lights facing +x) at points of the floor.
double share_facing_up(const Scene& scene, const GpuScene& g) {
    std::mt19937 rng(2);
    std::uniform_real_distribution<float> pos(-8.f, 8.f);
    double up = 0;
    for (int k = 0; k < 16; ++k) {
        const glm::vec3 x(pos(rng), 0.f, pos(rng));
        for (const gpu::GpuLight& l : g.lights) {
            const Triangle& t = scene.triangles.at(l.prim);
            if (glm::cross(t.v1 - t.v0, t.v2 - t.v0).x > 0)
                up += gpu::light_tree_pmf(TREE_ARGS x, glm::vec3(0.f),
                                          gpu::light_tree_trail(TREE_ARGS l.prim));
        }
    }
    return up / 16;
}

// Every node's cos_o set to -1 (no cones) or its axis negated (cones turned the wrong way).
void strip_cones(GpuScene& g) {
    for (uint32_t i = 0; i + 1 < 2 * g.params.num_tree_lights; ++i)
        g.texels[g.params.light_tree_word + 12u * i + 11u] = float_word(-1.f);
}
void turn_cones(GpuScene& g) {
    for (uint32_t i = 0; i + 1 < 2 * g.params.num_tree_lights; ++i)
        for (uint32_t k = 8; k < 11; ++k) {
            uint32_t& w = g.texels[g.params.light_tree_word + 12u * i + k];
            w = float_word(-word_float(w));
        }
}

// How --light-sampling sets a scene's light choice: "power", "tree" or "contribution".
std::string light_choice(Scene s, const std::string& how) {
    LightingArgs a;
    a.light_sampling = how;
    apply_light_sampling(s, a);
    EXPECT_FALSE(s.light_tree && s.light_by_contribution);
    return s.light_tree ? "tree" : s.light_by_contribution ? "contribution" : "power";
}

// --light-sampling auto: by contribution where every light is a lamp and there are 2 to 8;
// else the tree from 32 local lights on (emitters and lamps; a directional lamp is not local),
// or from 2 where one is a point or spot lamp; power below; each as asked, contribution
// refused where it is not possible.
TEST(LightTree, AutoTakesTheTreeFromManyLightsOrLamps) {
    const auto emitters_only = [](int n) {
        Scene s = many_lights(n, 1);
        s.punctual_lights.clear();
        return s;
    };
    const Scene few = emitters_only(15), many = emitters_only(16);  // 30 and 32 triangles
    EXPECT_EQ(few.local_light_count(), 30u);
    EXPECT_EQ(many.local_light_count(), 32u);
    EXPECT_EQ(light_choice(few, "auto"), "power");
    EXPECT_EQ(light_choice(many, "auto"), "tree");
    EXPECT_EQ(light_choice(many, "power"), "power");
    EXPECT_EQ(light_choice(few, "tree"), "tree");
    EXPECT_THROW(light_choice(few, "contribution"), Error);
    // Lamps: one alone keeps power (nothing to choose); 2 to 8 lamps and nothing else, by
    // contribution; beside any other local light, the tree.
    Scene lamp = test::plane_scene(0.5f, 10.f, 1.f);
    PunctualLight point;
    point.kind = PunctualKind::Point;
    point.intensity = glm::vec3(1.f);
    lamp.punctual_lights.push_back(point);
    EXPECT_EQ(light_choice(lamp, "auto"), "power");
    EXPECT_EQ(light_choice(lamp, "contribution"), "contribution");
    Scene sun = lamp;
    for (int i = 0; i < 5; ++i) {
        PunctualLight l;
        l.kind = PunctualKind::Directional;
        l.intensity = glm::vec3(1.f);
        sun.punctual_lights.push_back(l);
    }
    EXPECT_EQ(sun.local_light_count(), 1u);
    EXPECT_EQ(light_choice(sun, "auto"), "contribution");
    EXPECT_EQ(light_choice(sun, "power"), "power");
    Scene two = lamp;
    two.punctual_lights.push_back(point);
    EXPECT_EQ(light_choice(two, "auto"), "contribution");
    EXPECT_EQ(light_choice(two, "tree"), "tree");
    Scene nine = two;
    while (nine.punctual_lights.size() < 9) nine.punctual_lights.push_back(point);
    EXPECT_EQ(light_choice(nine, "auto"), "tree");
    EXPECT_THROW(light_choice(nine, "contribution"), Error);
    Scene lit_by_map = two;
    lit_by_map.environment = test::map_with_sun(8, 4, 0.5f, 0, 0, 0.5f);
    EXPECT_EQ(light_choice(lit_by_map, "auto"), "tree");
    EXPECT_THROW(light_choice(lit_by_map, "contribution"), Error);
    Scene lamp_and_emitter = emitters_only(1);  // two triangles
    EXPECT_EQ(light_choice(lamp_and_emitter, "auto"), "power");
    lamp_and_emitter.punctual_lights.push_back(point);
    EXPECT_EQ(light_choice(lamp_and_emitter, "auto"), "tree");
    // The packed scene refuses the flag where it is not possible.
    Scene forced = lamp_and_emitter;
    forced.light_by_contribution = true;
    EXPECT_THROW(pack_scene(forced, build_kdtree(forced.triangles, TreeOptions{})), Error);
}

// At points on the floor the tree's picks leave the wall facing away: its share falls from
// what its power and distance give it to almost nothing.
TEST(LightTree, PicksAvoidLightsFacingAway) {
    const Scene scene = quads_and_a_bank_facing_away(200, 7);
    const GpuScene g = pack_scene(scene, build_kdtree(scene.triangles, TreeOptions{}));
    GpuScene stripped = g;
    strip_cones(stripped);
    const double with = share_facing_up(scene, g), without = share_facing_up(scene, stripped);
    std::printf("share of the picks facing away: %.4f with cones, %.4f without\n", with, without);
    EXPECT_LT(with, 0.02);
    EXPECT_GT(without, 0.1);
}

// A bright wall of quads beside the floor, facing away from it: with the nodes' cones of
// emission the tree leaves it alone, and the variance per sample falls against the same
// tree without cones (1.94x measured on both APIs); cones turned the wrong way (each axis
// negated: the quads that light the floor keep a thousandth of their share) raise it instead
// (2.19x), and the means still agree (no light is ever left out).
TEST_P(LightTreeRender, ConesOfEmissionSkipLightsFacingAway) {
    const Scene scene = quads_and_a_bank_facing_away(200, 7);
    test::CaseRender how;
    how.spp = 64;
    const RenderResult cones = test::render_case(GetParam(), scene, 32, how);
    how.plant = strip_cones;
    const RenderResult none = test::render_case(GetParam(), scene, 32, how);
    how.plant = turn_cones;
    const RenderResult turned = test::render_case(GetParam(), scene, 32, how);
    const double vc = sample_variance(cones), vn = sample_variance(none),
                 vt = sample_variance(turned);
    const test::MeanEstimate mc = test::pooled_mean(cones), mn = test::pooled_mean(none),
                             mt = test::pooled_mean(turned);
    const double z_none = (mn.mean - mc.mean) / std::hypot(mn.std_error, mc.std_error);
    const double z_turned = (mt.mean - mc.mean) / std::hypot(mt.std_error, mc.std_error);
    std::printf(
        "%s, 200 quads and a wall facing away: variance per sample, no cones %.4g, "
        "cones %.4g (%.2fx less), cones turned %.4g (%.2fx more); z of the means %.2f, "
        "%.2f\n",
        GetParam().c_str(), vn, vc, vn / vc, vt, vt / vc, z_none, z_turned);
    EXPECT_GT(vn / vc, 1.5);
    // The control: the same check on the turned cones fails (it gains nothing on no cones).
    EXPECT_LT(vn / vt, 1.5);
    EXPECT_LT(std::abs(z_none), 4.5);
    EXPECT_LT(std::abs(z_turned), 4.5);
}

// The receiver's normal in the renderer (OpenCL: the variants are compile-time): the floor's
// next-event samples skip the storey below, so the variance per sample falls by more than 1.4x
// (1.58x here)
// against the tree without the normal, and the mean stays; MIS that forgets the normal at
// BSDF-sampled hits (the pick and the pmf disagree) is caught biased.
TEST(LightTreeRenderCl, ReceiverNormalSkipsTheStoreyBelow) {
    const Scene scene = two_storeys(150, 8, true);
    test::CaseRender how;
    how.spp = 64;
    const RenderResult with = test::render_case("opencl", scene, 32, how);
    how.defines = "-DMCPT_NO_RECEIVER_BOUND";
    const RenderResult without = test::render_case("opencl", scene, 32, how);
    how.defines = "-DMCPT_NEGATIVE_CONTROL_RECEIVER_MIS";
    how.spp = 256;
    const RenderResult forgets = test::render_case("opencl", scene, 32, how);
    const double vw = sample_variance(with), vn = sample_variance(without);
    const test::MeanEstimate mw = test::pooled_mean(with), mn = test::pooled_mean(without),
                             mf = test::pooled_mean(forgets);
    const double z_without = (mn.mean - mw.mean) / std::hypot(mn.std_error, mw.std_error);
    const double z_forgets = (mf.mean - mw.mean) / std::hypot(mf.std_error, mw.std_error);
    std::printf(
        "quads on two storeys: variance per sample %.4g with the normal, %.4g without "
        "(%.2fx); z of the means: without %.2f, MIS forgetting it %.2f\n",
        vw, vn, vn / vw, z_without, z_forgets);
    EXPECT_GT(vn / vw, 1.4);
    EXPECT_LT(std::abs(z_without), 4.5);
    EXPECT_GT(std::abs(z_forgets), 4.5);
}

INSTANTIATE_TEST_SUITE_P(Api, LightTreeRender, ::testing::ValuesIn(test::test_apis()),
                         [](const auto& info) { return info.param; });

}  // namespace
}  // namespace mcpt
