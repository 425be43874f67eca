// Built-in scenes. Winding matters: a triangle (v0, v1, v2) has the front normal
// cross(v1 - v0, v2 - v0), and only its front side emits, so every quad is checked against the
// normal it is meant to have.
#include "common/scene/builtin_scenes.h"

#include <cmath>

#include "common/error.h"

namespace mcpt {
namespace {

// Adds the quad a-b-c-d (counter-clockwise seen from its front side) as triangles (a, b, c) and
// (a, c, d); throws if either triangle's normal does not point along `normal`.
void add_quad(Scene& scene, const glm::vec3& a, const glm::vec3& b, const glm::vec3& c,
              const glm::vec3& d, const glm::vec3& normal, uint32_t material) {
    const glm::vec3 n1 = glm::cross(b - a, c - a), n2 = glm::cross(c - a, d - a);
    const float want = 0.999f * glm::length(normal);
    if (glm::dot(glm::normalize(n1), normal) < want || glm::dot(glm::normalize(n2), normal) < want)
        throw Error("internal error: built-in quad wound against its intended normal");
    scene.triangles.push_back({a, b, c, material});
    scene.triangles.push_back({a, c, d, material});
}

// Adds the six faces of the box [lo, hi] with normals pointing out of it, or into it if inward.
void add_box(Scene& scene, const glm::vec3& lo, const glm::vec3& hi, bool inward,
             uint32_t material) {
    for (int axis = 0; axis < 3; ++axis) {
        const int u = (axis + 1) % 3, v = (axis + 2) % 3;
        for (float side : {-1.f, 1.f}) {
            // The face plane, and corners ordered counter-clockwise around +axis.
            glm::vec3 corner[4];
            const float uv[4][2] = {{lo[u], lo[v]}, {hi[u], lo[v]}, {hi[u], hi[v]}, {lo[u], hi[v]}};
            for (int k = 0; k < 4; ++k) {
                corner[k][axis] = side > 0.f ? hi[axis] : lo[axis];
                corner[k][u] = uv[k][0];
                corner[k][v] = uv[k][1];
            }
            // The wanted normal; reverse the corners when it is -axis.
            glm::vec3 normal(0.f);
            normal[axis] = inward ? -side : side;
            if (normal[axis] > 0.f)
                add_quad(scene, corner[0], corner[1], corner[2], corner[3], normal, material);
            else
                add_quad(scene, corner[0], corner[3], corner[2], corner[1], normal, material);
        }
    }
}

Material diffuse(const std::string& name, const glm::vec3& color) {
    Material m;
    m.name = name;
    m.type = MaterialType::Diffuse;
    m.color = color;
    return m;
}

// Clear glass of IOR 1.5, and a mirror of the given tint.
Material clear_glass_material() {
    Material m;
    m.name = "glass";
    m.type = MaterialType::Glass;
    m.color = glm::vec3(1.f);
    m.ior = 1.5f;
    return m;
}
Material mirror_material(const glm::vec3& tint) {
    Material m;
    m.name = "mirror";
    m.type = MaterialType::Mirror;
    m.color = tint;
    return m;
}

// The Cornell box: x, z in [-1, 1], y in [0, 2], open towards the camera at +z.
Scene make_cornell() {
    Scene s;
    s.name = "cornell";
    const uint32_t white = s.add_material(diffuse("white", glm::vec3(0.73f)));
    const uint32_t red = s.add_material(diffuse("red", {0.65f, 0.05f, 0.05f}));
    const uint32_t green = s.add_material(diffuse("green", {0.12f, 0.45f, 0.15f}));
    Material light_m = diffuse("light", glm::vec3(0.f));
    light_m.emission = {17.f, 12.f, 4.f};
    const uint32_t light = s.add_material(light_m);
    const uint32_t glass = s.add_material(clear_glass_material());
    const uint32_t mirror = s.add_material(mirror_material(glm::vec3(0.95f)));

    // Walls, each facing into the box.
    add_quad(s, {-1, 0, -1}, {-1, 0, 1}, {1, 0, 1}, {1, 0, -1}, {0, 1, 0}, white);    // floor
    add_quad(s, {-1, 2, -1}, {1, 2, -1}, {1, 2, 1}, {-1, 2, 1}, {0, -1, 0}, white);   // ceiling
    add_quad(s, {-1, 0, -1}, {1, 0, -1}, {1, 2, -1}, {-1, 2, -1}, {0, 0, 1}, white);  // back
    add_quad(s, {-1, 0, -1}, {-1, 2, -1}, {-1, 2, 1}, {-1, 0, 1}, {1, 0, 0}, red);    // left
    add_quad(s, {1, 0, -1}, {1, 0, 1}, {1, 2, 1}, {1, 2, -1}, {-1, 0, 0}, green);     // right

    // The 0.5 x 0.5 area light just below the ceiling, facing down.
    const float h = 0.25f, y = 1.98f;
    add_quad(s, {-h, y, -h}, {h, y, -h}, {h, y, h}, {-h, y, h}, {0, -1, 0}, light);

    // A glass sphere front right, a mirror sphere back left.
    s.spheres.push_back({{0.45f, 0.35f, 0.3f}, 0.35f, glass});
    s.spheres.push_back({{-0.45f, 0.35f, -0.35f}, 0.35f, mirror});

    // The classic camera in front of the open side.
    s.camera.position = {0.f, 1.f, 3.9f};
    s.camera.forward = {0.f, 0.f, -1.f};
    s.camera.up = {0.f, 1.f, 0.f};
    s.camera.yfov = 0.6911f;
    s.has_camera = true;
    s.max_depth_hint = 0;
    return s;
}

// Spheres only, lit by a spherical light: a ground sphere, glass, mirror and diffuse
// spheres on it (no triangles, so no tree and no triangle code).
Scene make_spheres() {
    Scene s;
    s.name = "spheres";
    const uint32_t ground = s.add_material(diffuse("ground", glm::vec3(0.6f, 0.6f, 0.55f)));
    const uint32_t blue = s.add_material(diffuse("blue", {0.15f, 0.25f, 0.65f}));
    Material light_m = diffuse("light", glm::vec3(0.f));
    light_m.emission = glm::vec3(40.f, 36.f, 30.f);
    const uint32_t light = s.add_material(light_m);
    const uint32_t glass = s.add_material(clear_glass_material());
    const uint32_t mirror = s.add_material(mirror_material(glm::vec3(0.9f)));

    // The ground: a sphere of radius 1000 whose top is y = 0.
    s.spheres.push_back({{0.f, -1000.f, 0.f}, 1000.f, ground});
    s.spheres.push_back({{-0.9f, 0.4f, 0.f}, 0.4f, glass});
    s.spheres.push_back({{0.f, 0.4f, -0.6f}, 0.4f, mirror});
    s.spheres.push_back({{0.9f, 0.4f, 0.f}, 0.4f, blue});
    s.spheres.push_back({{0.5f, 2.2f, 1.0f}, 0.3f, light});

    s.camera.position = {0.f, 1.0f, 3.5f};
    s.camera.forward = glm::normalize(glm::vec3(0.f, -0.2f, -1.f));
    s.camera.up = glm::normalize(
        glm::cross(glm::cross(s.camera.forward, glm::vec3(0, 1, 0)), s.camera.forward));
    s.camera.yfov = 0.6911f;
    s.has_camera = true;
    return s;
}

// A metallic-roughness material (glTF's pbrMetallicRoughness factors).
Material pbr_material(const std::string& name, const glm::vec3& base, float metallic,
                      float roughness) {
    Material m;
    m.name = name;
    m.type = MaterialType::Pbr;
    m.color = base;
    m.metallic = metallic;
    m.roughness = roughness;
    return m;
}

// The Cornell box with glTF metallic-roughness spheres: rough gold, a glossy blue dielectric
// (plastic), a rough white dielectric and frosted glass, and a polished steel back wall.
Scene make_materials() {
    Scene s = make_cornell();
    s.name = "materials";
    s.spheres.clear();
    const uint32_t gold = s.add_material(pbr_material("gold", {1.f, 0.78f, 0.34f}, 1.f, 0.35f));
    const uint32_t plastic =
        s.add_material(pbr_material("blue plastic", {0.1f, 0.2f, 0.6f}, 0.f, 0.15f));
    const uint32_t chalk = s.add_material(pbr_material("rough white", glm::vec3(0.8f), 0.f, 0.7f));
    const uint32_t steel = s.add_material(pbr_material("steel", glm::vec3(0.6f), 1.f, 0.2f));
    s.triangles[4].material = s.triangles[5].material = steel;  // the back wall
    s.spheres.push_back({{-0.5f, 0.3f, -0.3f}, 0.3f, gold});
    s.spheres.push_back({{0.5f, 0.3f, -0.2f}, 0.3f, plastic});
    s.spheres.push_back({{0.f, 0.25f, 0.45f}, 0.25f, chalk});
    // Frosted glass (a rough dielectric) between the gold and the plastic, at the back.
    Material frosted = clear_glass_material();
    frosted.name = "frosted glass";
    frosted.type = MaterialType::RoughGlass;
    frosted.roughness = 0.3f;
    s.spheres.push_back({{0.f, 0.3f, -0.65f}, 0.3f, s.add_material(frosted)});
    return s;
}

}  // namespace

std::vector<std::string> builtin_scene_names() {
    return {"cornell", "furnace", "spheres", "materials"};
}

Scene make_builtin_scene(const std::string& name) {
    if (name == "cornell") return make_cornell();
    if (name == "furnace") return make_furnace_scene(0.5f, 1.f);
    if (name == "spheres") return make_spheres();
    if (name == "materials") return make_materials();
    // Unknown: list the valid names.
    std::string valid;
    for (const std::string& n : builtin_scene_names()) valid += (valid.empty() ? "" : ", ") + n;
    throw Error("unknown built-in scene '" + name + "' (valid: " + valid + ")");
}

// The Cornell box with its spheres replaced by a bumpy tessellated sphere of
// 2 * segments^2 diffuse triangles: a mesh deep enough for a deep SAH tree.
Scene make_bumpy_sphere_scene(int segments) {
    Scene scene = make_cornell();
    scene.name = "generated-sphere";
    scene.spheres.clear();
    Material m;
    m.name = "bumpy";
    m.color = glm::vec3(0.7f, 0.6f, 0.5f);
    const uint32_t mat = scene.add_material(m);
    auto point = [&](int i, int j) {
        const float theta = float(M_PI) * float(i) / float(segments);
        const float phi = 2.f * float(M_PI) * float(j) / float(segments);
        const float r = 0.45f * (1.f + 0.08f * std::sin(7.f * theta) * std::sin(9.f * phi));
        return glm::vec3(r * std::sin(theta) * std::cos(phi), 0.5f + r * std::cos(theta),
                         r * std::sin(theta) * std::sin(phi));
    };
    for (int i = 0; i < segments; ++i) {
        for (int j = 0; j < segments; ++j) {
            // Two triangles per quad, counter-clockwise seen from outside.
            const glm::vec3 a = point(i, j), b = point(i + 1, j), c = point(i + 1, j + 1),
                            d = point(i, j + 1);
            scene.triangles.push_back({a, d, c, mat});
            scene.triangles.push_back({a, c, b, mat});
        }
    }
    return scene;
}

// Every surface has albedo a and emits Le, and the enclosure is closed, so the radiance L leaving
// any point in any direction solves L = Le + a * L, i.e. exactly
//     L = Le / (1 - a)
// (0.5 / 1 gives L = 2). Paths are unbounded (Russian roulette ends them), hence the huge
// max_depth_hint.
Scene make_furnace_scene(float albedo, float emission) {
    if (!(albedo >= 0.f && albedo < 1.f))
        throw Error("furnace albedo must be in [0, 1), got " + std::to_string(albedo));
    if (!(std::isfinite(emission) && emission > 0.f))
        throw Error("furnace emission must be finite and > 0, got " + std::to_string(emission));
    Scene s;
    s.name = "furnace";
    Material m = diffuse("furnace", glm::vec3(albedo));
    m.emission = glm::vec3(emission);
    const uint32_t mat = s.add_material(m);

    // The closed enclosure [-2, 2]^3 facing inward.
    add_box(s, glm::vec3(-2.f), glm::vec3(2.f), /*inward=*/true, mat);
    // A sphere and a closed small cube (side 0.8) inside it, facing outward.
    s.spheres.push_back({{0.6f, -0.8f, 0.f}, 0.6f, mat});
    const glm::vec3 cube_center(-0.7f, -0.6f, 0.3f);
    add_box(s, cube_center - glm::vec3(0.4f), cube_center + glm::vec3(0.4f), /*inward=*/false, mat);

    // The camera inside, near the +z wall, looking at -z.
    s.camera.position = {0.f, 0.f, 1.9f};
    s.camera.forward = {0.f, 0.f, -1.f};
    s.camera.up = {0.f, 1.f, 0.f};
    s.camera.yfov = 0.6911f;
    s.has_camera = true;
    s.max_depth_hint = 100000;
    return s;
}

}  // namespace mcpt
