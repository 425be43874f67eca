// validate_scene(), Scene::bounds(), frame_camera() and the built-in scenes, including the
// orientation of every built-in wall and light.
#include "common/scene/scene.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>

#include "common/error.h"
#include "common/scene/builtin_scenes.h"
#include "common/scene/environment.h"

namespace mcpt {
namespace {

glm::vec3 normal(const Triangle& t) {
    return glm::normalize(glm::cross(t.v1 - t.v0, t.v2 - t.v0));
}
glm::vec3 centroid(const Triangle& t) {
    return (t.v0 + t.v1 + t.v2) / 3.f;
}

// A scene with one emissive triangle (material 0) and a grey diffuse material 1.
Scene lit_scene() {
    Scene s;
    s.name = "test";
    Material light;
    light.name = "light";
    light.emission = glm::vec3(1.f);
    s.add_material(light);
    Material grey;
    grey.name = "grey";
    s.add_material(grey);
    s.triangles.push_back({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, 0});
    return s;
}

// Runs validate_scene and returns the error message ("" if it did not throw).
std::string validation_error(Scene s) {
    try {
        validate_scene(s);
    } catch (const Error& e) {
        return e.what();
    }
    return "";
}

TEST(Scene, ValidScenePasses) {
    Scene s = lit_scene();
    const ValidationReport r = validate_scene(s);
    EXPECT_EQ(r.degenerate_dropped, 0u);
    EXPECT_EQ(s.triangles.size(), 1u);
}

TEST(Scene, RejectsNanAndInfVertices) {
    const float nan = std::numeric_limits<float>::quiet_NaN();
    const float inf = std::numeric_limits<float>::infinity();
    Scene s = lit_scene();
    s.triangles.push_back({{0, 0, 0}, {1, nan, 0}, {0, 1, 0}, 1});
    std::string e = validation_error(s);
    EXPECT_NE(e.find("triangle 1"), std::string::npos) << e;
    EXPECT_NE(e.find("non-finite vertex v1"), std::string::npos) << e;
    EXPECT_NE(e.find("grey"), std::string::npos) << e;

    s.triangles[1].v1.y = 0.f;
    s.triangles[1].v2.z = -inf;
    e = validation_error(s);
    EXPECT_NE(e.find("non-finite vertex v2"), std::string::npos) << e;
}

TEST(Scene, RejectsEmptyScene) {
    Scene s;
    s.add_material(Material{});
    EXPECT_NE(validation_error(s).find("empty"), std::string::npos);
}

std::string unlit_error(const Scene& s) {
    try {
        check_lit(s);
    } catch (const Error& e) {
        return e.what();
    }
    return "";
}

// No light at all is refused, naming the ways to light a scene; an emissive sphere, a lamp
// or an environment is a light.
TEST(Scene, RejectsSceneWithoutLight) {
    Scene s = lit_scene();
    s.triangles[0].material = 1;
    s.spheres.push_back({{0, 0, 0}, 1.f, 1});
    const std::string e = unlit_error(s);
    for (const char* way :
         {"scene has no light", "emissiveFactor", "KHR_lights_punctual", "--env", "--background"})
        EXPECT_NE(e.find(way), std::string::npos) << way << " in " << e;
    s.spheres[0].material = 0;
    EXPECT_EQ(unlit_error(s), "");
    s.spheres[0].material = 1;
    s.punctual_lights.push_back({});
    EXPECT_NE(unlit_error(s), "") << "a lamp of intensity 0 is no light";
    s.punctual_lights[0].intensity = glm::vec3(1.f);
    EXPECT_EQ(unlit_error(s), "");
    s.punctual_lights.clear();
    s.environment = constant_environment(glm::vec3(0.f));
    EXPECT_NE(unlit_error(s), "") << "a black environment is no light";
    s.environment = constant_environment(glm::vec3(0.5f));
    EXPECT_EQ(unlit_error(s), "");
}

TEST(Scene, RejectsBadMaterialsAndSpheres) {
    const float nan = std::numeric_limits<float>::quiet_NaN();
    Scene s = lit_scene();
    s.triangles[0].material = 7;
    EXPECT_NE(validation_error(s).find("material index 7 out of range"), std::string::npos);

    s = lit_scene();
    s.materials[1].emission = glm::vec3(-1.f, 0.f, 0.f);
    EXPECT_NE(validation_error(s).find("negative emission"), std::string::npos);
    s.materials[1].emission = glm::vec3(0.f);
    s.materials[1].color = glm::vec3(0.5f, -0.1f, 0.5f);
    EXPECT_NE(validation_error(s).find("negative color"), std::string::npos);
    s.materials[1].color = glm::vec3(nan);
    EXPECT_NE(validation_error(s).find("non-finite color"), std::string::npos);
    s.materials[1].color = glm::vec3(1.f);
    s.materials[1].type = MaterialType::Glass;
    s.materials[1].ior = 0.f;
    EXPECT_NE(validation_error(s).find("ior"), std::string::npos);
    s.materials[1].ior = 1.5f;
    EXPECT_EQ(validation_error(s), "");
    // Metallic-roughness factors are fractions (NaN included), and so is the base color.
    s.materials[1].type = MaterialType::Pbr;
    EXPECT_EQ(validation_error(s), "");
    s.materials[1].roughness = nan;
    EXPECT_NE(validation_error(s).find("roughness"), std::string::npos);
    s.materials[1].roughness = 0.5f;
    s.materials[1].metallic = 1.5f;
    EXPECT_NE(validation_error(s).find("metallic"), std::string::npos);
    s.materials[1].metallic = 1.f;
    s.materials[1].color = glm::vec3(1.f, 2.f, 1.f);
    EXPECT_NE(validation_error(s).find("base color above 1"), std::string::npos);
    s.materials[1].color = glm::vec3(1.f);
    s.materials[1].ior = -1.f;
    EXPECT_NE(validation_error(s).find("ior"), std::string::npos);
    s.materials[1].ior = 1.5f;
    EXPECT_EQ(validation_error(s), "");

    s.spheres.push_back({{0, 0, 0}, 0.f, 1});
    EXPECT_NE(validation_error(s).find("radius"), std::string::npos);
    s.spheres[0].radius = std::numeric_limits<float>::infinity();
    EXPECT_NE(validation_error(s).find("radius"), std::string::npos);
    s.spheres[0].radius = 1.f;
    s.spheres[0].center.x = nan;
    EXPECT_NE(validation_error(s).find("non-finite center"), std::string::npos);
    s.spheres[0].center.x = 0.f;
    s.spheres[0].material = 2;
    EXPECT_NE(validation_error(s).find("sphere 0: material index 2"), std::string::npos);
}

TEST(Scene, DropsZeroAreaAndCollinearTriangles) {
    Scene s = lit_scene();
    s.triangles.push_back({{1, 2, 3}, {1, 2, 3}, {1, 2, 3}, 1});  // zero area (a point)
    s.triangles.push_back({{0, 0, 0}, {1, 1, 1}, {3, 3, 3}, 1});  // collinear
    s.triangles.push_back({{0, 0, 0}, {1, 0, 0}, {0, 0, 1}, 1});  // fine
    s.triangles.push_back({{0, 0, 0}, {1, 0, 0}, {0, 0, 1}, 1});  // duplicate: kept
    const ValidationReport r = validate_scene(s);
    EXPECT_EQ(r.degenerate_dropped, 2u);
    ASSERT_EQ(s.triangles.size(), 3u);
    EXPECT_EQ(s.triangles[1].v2, glm::vec3(0, 0, 1));
}

TEST(Scene, AllDegenerateIsEmpty) {
    Scene s = lit_scene();
    s.triangles[0].v2 = glm::vec3(2, 0, 0);
    EXPECT_NE(validation_error(s).find("degenerate"), std::string::npos);
}

TEST(Scene, BoundsCoverTrianglesAndSpheres) {
    Scene s = lit_scene();
    s.spheres.push_back({{5, 0, 0}, 2.f, 1});
    const Bounds b = s.bounds();
    EXPECT_EQ(b.min, glm::vec3(0, -2, -2));
    EXPECT_EQ(b.max, glm::vec3(7, 2, 2));
    EXPECT_TRUE(Scene{}.bounds().empty());
}

TEST(Scene, FrameCameraFitsBoundingSphere) {
    Scene s = lit_scene();
    s.spheres.push_back({{0, 0, -4}, 1.f, 1});
    frame_camera(s);
    ASSERT_TRUE(s.has_camera);
    const Bounds b = s.bounds();
    const glm::vec3 center = 0.5f * (b.min + b.max);
    const float radius = 0.5f * glm::length(b.max - b.min);
    EXPECT_EQ(s.camera.forward, glm::vec3(0, 0, -1));
    EXPECT_EQ(s.camera.up, glm::vec3(0, 1, 0));
    EXPECT_NEAR(s.camera.position.x, center.x, 1e-5f);
    EXPECT_NEAR(s.camera.position.y, center.y, 1e-5f);
    const float distance = s.camera.position.z - center.z;
    EXPECT_NEAR(std::asin(radius / distance), 0.5f * s.camera.yfov, 1e-4f);
    EXPECT_EQ(validation_error(s), "");
}

TEST(BuiltinScenes, NamesAndUnknownName) {
    const auto names = builtin_scene_names();
    ASSERT_GE(names.size(), 2u);
    EXPECT_EQ(names[0], "cornell");
    try {
        make_builtin_scene("nope");
        FAIL() << "expected mcpt::Error";
    } catch (const Error& e) {
        const std::string m = e.what();
        EXPECT_NE(m.find("nope"), std::string::npos) << m;
        EXPECT_NE(m.find("cornell"), std::string::npos) << m;
        EXPECT_NE(m.find("furnace"), std::string::npos) << m;
    }
}

TEST(BuiltinScenes, CornellValidatesAndFacesInward) {
    Scene s = make_builtin_scene("cornell");
    EXPECT_EQ(validate_scene(s).degenerate_dropped, 0u);
    EXPECT_TRUE(s.has_camera);
    EXPECT_EQ(s.camera.position, glm::vec3(0, 1, 3.9f));
    EXPECT_EQ(s.camera.forward, glm::vec3(0, 0, -1));
    EXPECT_EQ(s.max_depth_hint, 0);
    ASSERT_EQ(s.triangles.size(), 12u);  // 5 walls + the light, 2 triangles each
    int light_triangles = 0;
    for (const Triangle& t : s.triangles) {
        const glm::vec3 n = normal(t);
        if (s.materials[t.material].is_emissive()) {
            // The light: just below the ceiling, facing down, 0.5 x 0.5.
            ++light_triangles;
            EXPECT_NEAR(n.y, -1.f, 1e-6f);
            EXPECT_FLOAT_EQ(t.v0.y, 1.98f);
            EXPECT_NEAR(0.5f * glm::length(glm::cross(t.v1 - t.v0, t.v2 - t.v0)), 0.125f, 1e-6f);
        } else {
            // A wall: its normal points to the box center.
            EXPECT_GT(glm::dot(n, glm::vec3(0, 1, 0) - centroid(t)), 0.5f);
        }
    }
    EXPECT_EQ(light_triangles, 2);
    // Red on the left (-x), green on the right (+x); a glass and a mirror sphere.
    for (const Triangle& t : s.triangles) {
        const Material& m = s.materials[t.material];
        if (m.name == "red") {
            EXPECT_EQ(centroid(t).x, -1.f);
        }
        if (m.name == "green") {
            EXPECT_EQ(centroid(t).x, 1.f);
        }
    }
    ASSERT_EQ(s.spheres.size(), 2u);
    EXPECT_EQ(s.materials[s.spheres[0].material].type, MaterialType::Glass);
    EXPECT_FLOAT_EQ(s.materials[s.spheres[0].material].ior, 1.5f);
    EXPECT_EQ(s.materials[s.spheres[1].material].type, MaterialType::Mirror);
}

TEST(BuiltinScenes, FurnaceValidatesAndFacesCorrectly) {
    Scene s = make_builtin_scene("furnace");
    EXPECT_EQ(validate_scene(s).degenerate_dropped, 0u);
    EXPECT_EQ(s.max_depth_hint, 100000);
    EXPECT_EQ(s.camera.position, glm::vec3(0, 0, 1.9f));
    ASSERT_EQ(s.materials.size(), 1u);
    EXPECT_EQ(s.materials[0].color, glm::vec3(0.5f));
    EXPECT_EQ(s.materials[0].emission, glm::vec3(1.f));
    ASSERT_EQ(s.triangles.size(), 24u);
    ASSERT_EQ(s.spheres.size(), 1u);
    // The enclosure: 12 triangles on the [-2, 2]^3 box facing its center.
    for (int i = 0; i < 12; ++i) {
        const Triangle& t = s.triangles[i];
        const glm::vec3 c = centroid(t);
        EXPECT_FLOAT_EQ(std::max({std::abs(c.x), std::abs(c.y), std::abs(c.z)}), 2.f);
        EXPECT_GT(glm::dot(normal(t), -c), 0.f) << "enclosure triangle " << i;
    }
    // The small cube: 12 triangles facing away from its center.
    const glm::vec3 cube(-0.7f, -0.6f, 0.3f);
    for (int i = 12; i < 24; ++i) {
        const Triangle& t = s.triangles[i];
        EXPECT_GT(glm::dot(normal(t), centroid(t) - cube), 0.f) << "cube triangle " << i;
        EXPECT_NEAR(0.5f * glm::length(glm::cross(t.v1 - t.v0, t.v2 - t.v0)), 0.32f, 1e-5f);
    }
}

TEST(BuiltinScenes, FurnaceRejectsBadParameters) {
    EXPECT_THROW(make_furnace_scene(1.f, 1.f), Error);
    EXPECT_THROW(make_furnace_scene(-0.1f, 1.f), Error);
    EXPECT_THROW(make_furnace_scene(0.5f, 0.f), Error);
    Scene s = make_furnace_scene(0.8f, 2.f);
    EXPECT_EQ(s.materials[0].color, glm::vec3(0.8f));
    EXPECT_EQ(validate_scene(s).degenerate_dropped, 0u);
}

}  // namespace
}  // namespace mcpt
