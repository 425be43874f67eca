// Scene bounds, validation (bad input throws mcpt::Error, degenerate triangles are dropped) and
// automatic camera framing.
#include "common/scene/scene.h"

#include <algorithm>
#include <cmath>
#include <glm/gtc/packing.hpp>
#include <sstream>

#include "common/error.h"

namespace mcpt {
namespace {

constexpr float kDefaultYfov = 0.6911f;  // radians, the Cornell box camera
constexpr float kPi = 3.14159265358979f;

// A vector as "(x, y, z)" for error messages.
std::string str(const glm::vec3& v) {
    std::ostringstream s;
    s << "(" << v.x << ", " << v.y << ", " << v.z << ")";
    return s.str();
}

bool finite(const glm::vec3& v) {
    return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z);
}

bool non_negative(const glm::vec3& v) {
    return v.x >= 0.f && v.y >= 0.f && v.z >= 0.f;
}

// "material 2 'glass'" (or just "material 2" when unnamed).
std::string material_label(const Scene& scene, uint32_t index) {
    std::string label = "material " + std::to_string(index);
    if (index < scene.materials.size() && !scene.materials[index].name.empty())
        label += " '" + scene.materials[index].name + "'";
    return label;
}

void check_material(const Scene& scene, uint32_t i) {
    const Material& m = scene.materials[i];
    const std::string what = material_label(scene, i) + ": ";
    // Every value finite, then the physical ranges.
    if (!finite(m.color)) throw Error(what + "non-finite color " + str(m.color));
    if (!finite(m.emission)) throw Error(what + "non-finite emission " + str(m.emission));
    if (!std::isfinite(m.ior)) throw Error(what + "non-finite ior");
    if (!non_negative(m.color)) throw Error(what + "negative color " + str(m.color));
    if (!non_negative(m.emission)) throw Error(what + "negative emission " + str(m.emission));
    const auto type = static_cast<uint32_t>(m.type);
    if (type > static_cast<uint32_t>(MaterialType::RoughGlass))
        throw Error(what + "unknown material type " + std::to_string(type));
    if ((m.type == MaterialType::Glass || m.type == MaterialType::Pbr ||
         m.type == MaterialType::RoughGlass) &&
        !(m.ior > 0.f))
        throw Error(what + "ior must be > 0, got " + std::to_string(m.ior));
    // Absorption: finite and non-negative (an opaque inside is glass's business, not this).
    if (!finite(m.absorption) || !non_negative(m.absorption))
        throw Error(what + "absorption must be finite and >= 0, got " + str(m.absorption));
    if (m.type == MaterialType::RoughGlass && !(m.roughness >= 0.f && m.roughness <= 1.f))
        throw Error(what + "roughness must be in [0, 1], got " + std::to_string(m.roughness));
    if (m.type == MaterialType::Pbr) {
        // Metallic-roughness factors are fractions, and so is the base color (it is a Fresnel
        // reflectance of the metal).
        const auto fraction = [](float x) { return x >= 0.f && x <= 1.f; };
        if (!fraction(m.metallic) || !fraction(m.roughness) || !fraction(m.specular))
            throw Error(what + "metallic, roughness and specular must be in [0, 1], got " +
                        std::to_string(m.metallic) + ", " + std::to_string(m.roughness) + ", " +
                        std::to_string(m.specular));
        if (!(m.color.x <= 1.f && m.color.y <= 1.f && m.color.z <= 1.f))
            throw Error(what + "base color above 1 " + str(m.color));
    }
}

// Attributes one per triangle and finite, texture indices valid, textures whole and finite.
void check_attributes_and_textures(const Scene& scene) {
    if (!scene.attributes.empty() && scene.attributes.size() != scene.triangles.size())
        throw Error("per-vertex attributes of " + std::to_string(scene.attributes.size()) +
                    " triangles for " + std::to_string(scene.triangles.size()) + " triangles");
    for (size_t i = 0; i < scene.attributes.size(); ++i) {
        const VertexAttributes& a = scene.attributes[i];
        for (int k = 0; k < 3; ++k)
            if (!finite(a.n[k]) || !std::isfinite(a.uv[k].x) || !std::isfinite(a.uv[k].y))
                throw Error("triangle " + std::to_string(i) +
                            ": non-finite normal or texture "
                            "coordinate at vertex " +
                            std::to_string(k));
    }
    for (size_t i = 0; i < scene.textures.size(); ++i) {
        const Texture& t = scene.textures[i];
        const std::string what =
            "texture " + std::to_string(i) + (t.name.empty() ? "" : " '" + t.name + "'") + ": ";
        if (t.width <= 0 || t.height <= 0 || t.width > 16384 || t.height > 16384)
            throw Error(what + "size " + std::to_string(t.width) + "x" + std::to_string(t.height) +
                        " outside 1x1 to 16384x16384");
        if (t.rgba.size() != size_t(t.width) * size_t(t.height) * 4)
            throw Error(what + "texel count does not match its size");
        for (uint16_t v : t.rgba)
            if ((v & 0x7c00u) == 0x7c00u) throw Error(what + "non-finite texel");
    }
    for (uint32_t i = 0; i < scene.materials.size(); ++i) {
        const Material& m = scene.materials[i];
        for (int tex : {m.tex_base, m.tex_metal_rough, m.tex_normal, m.tex_emission})
            if (tex < -1 || tex >= int(scene.textures.size()))
                throw Error(material_label(scene, i) + ": texture index " + std::to_string(tex) +
                            " out of range (scene has " + std::to_string(scene.textures.size()) +
                            " textures)");
        if (!(m.alpha_cutoff >= 0.f))
            throw Error(material_label(scene, i) + ": alpha cutoff must be >= 0");
    }
}

void check_material_index(const Scene& scene, uint32_t index, const std::string& owner) {
    if (index >= scene.materials.size())
        throw Error(owner + ": material index " + std::to_string(index) +
                    " out of range (scene has " + std::to_string(scene.materials.size()) +
                    " materials)");
}

// Zero area or collinear, judged in double precision (float differences and their products are
// then nearly exact) against a tiny threshold relative to the longest edge squared.
bool degenerate(const Triangle& t) {
    const glm::dvec3 a(t.v0), b(t.v1), c(t.v2);
    const glm::dvec3 e1 = b - a, e2 = c - a, e3 = c - b;
    const double longest2 = std::max({glm::dot(e1, e1), glm::dot(e2, e2), glm::dot(e3, e3)});
    if (!(longest2 > 0.0)) return true;
    return glm::length(glm::cross(e1, e2)) <= 1e-12 * longest2;
}

void check_camera(const Camera& c) {
    if (!finite(c.position) || !finite(c.forward) || !finite(c.up))
        throw Error("camera: non-finite position, forward or up vector");
    if (!(c.yfov > 0.f && c.yfov < kPi))
        throw Error("camera: vertical field of view must be in (0, pi) radians, got " +
                    std::to_string(c.yfov));
    const float fl = glm::length(c.forward), ul = glm::length(c.up);
    if (!(fl > 0.f) || !(ul > 0.f)) throw Error("camera: zero-length forward or up vector");
    if (glm::length(glm::cross(c.forward / fl, c.up / ul)) < 1e-3f)
        throw Error("camera: forward and up vectors are parallel");
}

}  // namespace

size_t Scene::local_light_count() const {
    const auto emits = [&](uint32_t material) {
        if (material >= materials.size()) return false;
        const glm::vec3& e = materials[material].emission;
        return e.x > 0 || e.y > 0 || e.z > 0;
    };
    size_t n = 0;
    for (const Triangle& t : triangles) n += emits(t.material);
    for (const Sphere& s : spheres) n += emits(s.material);
    return n + lamp_count();
}

size_t Scene::lamp_count() const {
    size_t n = 0;
    for (const PunctualLight& l : punctual_lights) n += l.kind != PunctualKind::Directional;
    return n;
}

bool Scene::auto_light_tree() const {
    const size_t local = local_light_count();
    return local >= kAutoLightTreeMin || (local >= 2 && lamp_count() >= 1);
}

bool Scene::lamp_choice_possible() const {
    return local_light_count() == lamp_count() && !environment.present() &&
           punctual_lights.size() <= kLampChoiceMax;
}

bool Scene::auto_light_by_contribution() const {
    return punctual_lights.size() >= 2 && lamp_choice_possible();
}

void Scene::choose_lights_automatically() {
    light_by_contribution = auto_light_by_contribution();
    light_tree = !light_by_contribution && auto_light_tree();
}

Bounds Scene::bounds() const {
    Bounds b;
    // Triangle vertices.
    for (const Triangle& t : triangles) {
        b.extend(t.v0);
        b.extend(t.v1);
        b.extend(t.v2);
    }
    // Sphere boxes.
    for (const Sphere& s : spheres) {
        const glm::vec3 r(std::abs(s.radius));
        b.extend(s.center - r);
        b.extend(s.center + r);
    }
    return b;
}

Texture texture_from_rgba8(const std::string& name, int width, int height,
                           const unsigned char* rgba8, bool srgb) {
    // The 256 values of a channel, as halves.
    uint16_t linear[256], decoded[256];
    for (int i = 0; i < 256; ++i) {
        const float c = float(i) / 255.f;
        const float l = c <= 0.04045f ? c / 12.92f : std::pow((c + 0.055f) / 1.055f, 2.4f);
        linear[i] = glm::packHalf1x16(c);
        decoded[i] = glm::packHalf1x16(l);
    }
    Texture t;
    t.name = name;
    t.width = width, t.height = height;
    const size_t n = size_t(width) * size_t(height) * 4;
    t.rgba.resize(n);
    for (size_t i = 0; i < n; ++i)
        t.rgba[i] = (srgb && i % 4 != 3) ? decoded[rgba8[i]] : linear[rgba8[i]];
    return t;
}

ValidationReport validate_scene(Scene& scene) {
    ValidationReport report;
    // Something to render.
    if (scene.triangles.empty() && scene.spheres.empty())
        throw Error("scene '" + scene.name + "' is empty: no triangles and no spheres");

    // Materials: finite, non-negative, a valid type and a positive glass ior.
    for (uint32_t i = 0; i < scene.materials.size(); ++i) check_material(scene, i);

    // Triangles: a valid material and finite vertices.
    for (size_t i = 0; i < scene.triangles.size(); ++i) {
        const Triangle& t = scene.triangles[i];
        const std::string owner = "triangle " + std::to_string(i);
        check_material_index(scene, t.material, owner);
        const glm::vec3* v[3] = {&t.v0, &t.v1, &t.v2};
        for (int k = 0; k < 3; ++k)
            if (!finite(*v[k]))
                throw Error(owner + " (" + material_label(scene, t.material) +
                            "): non-finite vertex v" + std::to_string(k) + " = " + str(*v[k]));
    }

    // Spheres: a valid material, a finite center and a finite positive radius.
    for (size_t i = 0; i < scene.spheres.size(); ++i) {
        const Sphere& s = scene.spheres[i];
        const std::string owner = "sphere " + std::to_string(i);
        check_material_index(scene, s.material, owner);
        const std::string what = owner + " (" + material_label(scene, s.material) + "): ";
        const Material& m = scene.materials[s.material];
        if (m.tex_base >= 0 || m.tex_metal_rough >= 0 || m.tex_normal >= 0 || m.tex_emission >= 0 ||
            m.alpha_cutoff > 0.f)
            throw Error(what + "spheres have no texture coordinates: no textures or alpha mask");
        if (!finite(s.center)) throw Error(what + "non-finite center " + str(s.center));
        if (!std::isfinite(s.radius) || s.radius <= 0.f)
            throw Error(what + "radius must be finite and > 0, got " + std::to_string(s.radius));
    }

    // Camera, when the scene brings its own, and the bounce hint.
    if (scene.has_camera) check_camera(scene.camera);
    if (scene.max_depth_hint < 0)
        throw Error("max_depth_hint must be >= 0, got " + std::to_string(scene.max_depth_hint));

    // Per-vertex data and textures.
    check_attributes_and_textures(scene);

    // Drop degenerate triangles (and their attributes), keeping the order of the rest.
    const size_t before = scene.triangles.size();
    const bool with_attributes = !scene.attributes.empty();
    size_t kept = 0;
    for (size_t i = 0; i < before; ++i) {
        if (degenerate(scene.triangles[i])) continue;
        scene.triangles[kept] = scene.triangles[i];
        if (with_attributes) scene.attributes[kept] = scene.attributes[i];
        ++kept;
    }
    scene.triangles.resize(kept);
    if (with_attributes) scene.attributes.resize(kept);
    report.degenerate_dropped = before - scene.triangles.size();
    if (scene.triangles.empty() && scene.spheres.empty())
        throw Error("scene '" + scene.name + "' is empty: all " + std::to_string(before) +
                    " triangles are degenerate and there are no spheres");

    return report;
}

void check_lit(const Scene& scene) {
    const auto emits = [&](uint32_t m) { return scene.materials[m].is_emissive(); };
    const auto positive = [](const glm::vec3& v) {
        return std::isfinite(v.x + v.y + v.z) && (v.x > 0.f || v.y > 0.f || v.z > 0.f);
    };
    const bool lit = std::any_of(scene.triangles.begin(), scene.triangles.end(),
                                 [&](const Triangle& t) { return emits(t.material); }) ||
                     std::any_of(scene.spheres.begin(), scene.spheres.end(),
                                 [&](const Sphere& s) { return emits(s.material); }) ||
                     std::any_of(scene.punctual_lights.begin(), scene.punctual_lights.end(),
                                 [&](const PunctualLight& l) { return positive(l.intensity); }) ||
                     (scene.environment.present() && scene.environment.scale > 0.f &&
                      std::any_of(scene.environment.rgb.begin(), scene.environment.rgb.end(),
                                  [](float v) { return v > 0.f; }));
    if (!lit)
        throw Error(
            "scene has no light: light it with an emissive material (glTF emissiveFactor), a "
            "glTF lamp (KHR_lights_punctual), an environment map (--env FILE.exr|.hdr) or a "
            "background colour (--background R,G,B)");
}

void frame_camera(Scene& scene) {
    // Bounding sphere of the scene box (a unit sphere at the origin for an empty scene).
    const Bounds b = scene.bounds();
    glm::vec3 center(0.f);
    float radius = 1.f;
    if (!b.empty()) {
        center = 0.5f * (b.min + b.max);
        radius = 0.5f * glm::length(b.max - b.min);
        if (!(radius > 0.f)) radius = 1.f;
    }
    // Keep a valid fov, then back off along +z until the sphere fits it vertically.
    Camera& c = scene.camera;
    if (!(c.yfov > 0.f && c.yfov < kPi)) c.yfov = kDefaultYfov;
    const float distance = radius / std::sin(0.5f * c.yfov);
    c.position = center + glm::vec3(0.f, 0.f, distance);
    c.forward = glm::vec3(0.f, 0.f, -1.f);
    c.up = glm::vec3(0.f, 1.f, 0.f);
    scene.has_camera = true;
}

}  // namespace mcpt
