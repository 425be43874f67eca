// The scene model shared by every backend: triangles and spheres in world space, materials,
// and a pinhole camera. Loaders fill it; validate_scene() checks it; the k-d tree builder and
// the GPU packer (gpu_scene.h) read it.
#pragma once
#include <cstdint>
#include <glm/glm.hpp>
#include <string>
#include <vector>

namespace mcpt {

// Pbr: glTF metallic-roughness (GGX specular over a diffuse base, blended with a GGX metal).
// RoughGlass: a rough dielectric (GGX reflection and refraction, roughness and ior).
enum class MaterialType : uint32_t { Diffuse = 0, Mirror = 1, Glass = 2, Pbr = 3, RoughGlass = 4 };

struct Material {
    std::string name;
    MaterialType type = MaterialType::Diffuse;
    glm::vec3 color{0.8f};    // diffuse albedo, mirror tint or glass transmission tint
    glm::vec3 emission{0.f};  // emitted radiance; front side of triangles, outside of spheres
    bool two_sided = false;   // triangles emit from both faces (glTF doubleSided)
    float ior = 1.5f;
    float metallic = 0.f;   // Pbr: 0 dielectric over diffuse, 1 metal
    float roughness = 1.f;  // Pbr, RoughGlass: perceptual roughness (GGX alpha = roughness^2)
    float specular = 1.f;   // Pbr: KHR_materials_specular's factor
    // Textures (indices into Scene::textures, -1: none): base color (rgb times color; alpha),
    // metallic-roughness (b times metallic, g times roughness), tangent-space normals, emission
    // (rgb times emission).
    int tex_base = -1, tex_metal_rough = -1, tex_normal = -1, tex_emission = -1;
    // alphaMode MASK: cut out where the base alpha (factor times texture) < alpha_cutoff;
    // 0: opaque. Kept here as cutoff / alpha factor (the loader folds the factor in).
    float alpha_cutoff = 0.f;
    // Glass and RoughGlass: the inside's absorption coefficient per unit length (Beer-Lambert;
    // glTF KHR_materials_volume: -ln(attenuationColor) / attenuationDistance); 0: clear.
    glm::vec3 absorption{0.f};
    // Pbr: KHR_materials_clearcoat (a clear GGX coat of ior 1.5: weight, 0 none; perceptual
    // roughness) and KHR_materials_sheen (color, 0 none; roughness), with their textures (-1:
    // none): clearcoat (r), clearcoat roughness (g), sheen color (rgb), sheen roughness (a).
    float clearcoat = 0.f, clearcoat_roughness = 0.f;
    glm::vec3 sheen_color{0.f};
    float sheen_roughness = 0.f;
    int tex_clearcoat = -1, tex_clearcoat_roughness = -1, tex_sheen_color = -1,
        tex_sheen_roughness = -1;
    bool has_clearcoat() const { return clearcoat > 0.f; }
    bool has_sheen() const {
        return sheen_color.x > 0.f || sheen_color.y > 0.f || sheen_color.z > 0.f;
    }
    bool is_emissive() const { return emission.x > 0.f || emission.y > 0.f || emission.z > 0.f; }
};

struct Triangle {
    glm::vec3 v0, v1, v2;  // counter-clockwise seen from the front (emitting) side
    uint32_t material = 0;
};

// Per-corner data of a triangle (Scene::attributes): unit normals and texture coordinates 0.
struct VertexAttributes {
    glm::vec3 n[3]{glm::vec3(0.f), glm::vec3(0.f), glm::vec3(0.f)};
    glm::vec2 uv[3]{glm::vec2(0.f), glm::vec2(0.f), glm::vec2(0.f)};
};

// glTF's sampler wrap modes.
enum class TextureWrap : uint32_t { Repeat = 0, Clamp = 1, Mirror = 2 };

// A decoded texture: linear RGBA as IEEE half floats, row 0 at v = 0 (the top of the image,
// as glTF), exactly what the devices read.
struct Texture {
    std::string name;
    int width = 0, height = 0;
    std::vector<uint16_t> rgba;
    TextureWrap wrap_s = TextureWrap::Repeat, wrap_t = TextureWrap::Repeat;
    bool nearest = false;  // magnification filter NEAREST (else bilinear)
};

// A punctual light (glTF KHR_lights_punctual) in world space, in radiometric units: glTF's
// candela (point, spot) and lux (directional) divided by 683 lm/W, as Blender's importer does.
enum class PunctualKind : uint32_t { Point = 0, Spot = 1, Directional = 2 };
struct PunctualLight {
    std::string name;
    PunctualKind kind = PunctualKind::Point;
    glm::vec3 position{0.f};
    glm::vec3 direction{0.f, 0.f, -1.f};  // unit: the way the light travels (spot, directional)
    glm::vec3 intensity{0.f};  // W/sr (point, spot), W/m^2 (directional): color * intensity
    float range = 0.f;         // 0: unbounded; else glTF's window (1 - (d/range)^4) on 1/d^2
    float inner_cone = 0.f, outer_cone = 0.7853982f;  // spot: radians, 0 <= inner <= outer
};

// Light from every direction no surface covers: an equirectangular map of linear radiance
// (Blender's orientation seen through glTF's axes: row 0 at +Y, u = 0.5 at +X, u growing
// towards +Z), or a constant background (a map of one colour). Turned by rotate_deg about +Y and
// scaled by `scale`. Radiance between texel centres is bilinear.
struct Environment {
    std::string name;           // the file, or "background"
    int width = 0, height = 0;  // 0: none
    std::vector<float> rgb;     // width * height texels, row 0 first
    float rotate_deg = 0.f;
    float scale = 1.f;
    // Next-event estimation samples texels by max(luminance - mean, 0) x sin(theta), leaving
    // what is below the map's mean to BSDF sampling (MIS compensation, Karlik et al. 2019);
    // false: by luminance x sin(theta) (A/B measurements, and tests of NEE alone).
    bool compensated = true;
    bool present() const { return width > 0 && height > 0; }
};

struct Sphere {
    glm::vec3 center{0.f};
    float radius = 1.f;
    uint32_t material = 0;
};

struct Camera {
    glm::vec3 position{0.f, 0.f, 5.f};
    glm::vec3 forward{0.f, 0.f, -1.f};  // unit
    glm::vec3 up{0.f, 1.f, 0.f};        // unit, orthogonal to forward
    float yfov = 0.6911f;               // vertical field of view, radians
};

struct Bounds {
    glm::vec3 min{1e30f}, max{-1e30f};
    void extend(const glm::vec3& p) { min = glm::min(min, p), max = glm::max(max, p); }
    void extend(const Bounds& b) { min = glm::min(min, b.min), max = glm::max(max, b.max); }
    bool empty() const { return min.x > max.x || min.y > max.y || min.z > max.z; }
};

struct Scene {
    std::string name;
    std::vector<Material> materials;
    std::vector<Triangle> triangles;
    std::vector<Sphere> spheres;
    std::vector<VertexAttributes> attributes;  // empty, or one per triangle
    bool vertex_normals = false;               // attributes carry normals (else zero)
    std::vector<Texture> textures;
    std::vector<PunctualLight> punctual_lights;
    Environment environment;
    Camera camera;
    bool has_camera = false;  // false: frame the scene bounds automatically
    int max_depth_hint = 0;   // > 0: a bounce limit the scene asks for (0: the renderer's default)
    std::vector<std::string> warnings;  // unsupported features met while loading
    std::vector<std::string> extensions;  // glTF extensions the file uses, as it lists them
    // Next-event estimation picks local lights (emitters, point and spot lamps) by the light
    // tree (common/render/light_tree.h) where true; else every light by power.
    bool light_tree = false;
    // ... or, where true (and light_tree false), among a few lamps by each one's unshadowed
    // contribution at the shading point, the BSDF included (lamp_choice_possible()).
    bool light_by_contribution = false;
    // How next-event estimation samples emissive triangles (--triangle-light-sampling):
    // by solid angle, a rectangle's two halves as one (common/gpu/rect_light.h), warped toward
    // the receiver's cosine (pbrt-v4's bilinear warp) where the light spans 0.2 sr or more;
    // the same, uniform over the solid angle everywhere; warped everywhere; each triangle on
    // its own by solid angle (common/gpu/triangle_light.h); or by area. The last four are
    // what the first is measured against.
    enum class TriangleLightSampling { SolidAngle, Uniform, Cosine, Triangles, Area };
    TriangleLightSampling triangle_light_sampling = TriangleLightSampling::SolidAngle;
    // Emissive triangles and spheres, point and spot lamps: what the light tree holds.
    size_t local_light_count() const;
    // Point and spot lamps.
    size_t lamp_count() const;
    // --light-sampling auto: the tree from this many local lights on. Measured (PoCL, per
    // sample): 25 emitters around the furnace, the same variance and 1.2-1.4x the time;
    // 24-96 lights over a floor plan, 2.3-2.8x less variance.
    static constexpr size_t kAutoLightTreeMin = 32;
    // ... and from two local lights on where one is a lamp: a lamp has no extent and falls off
    // as 1/d^2, so its share of the power is its share of the light almost nowhere. Measured
    // (PoCL, per sample, docs/lights.md): a point and a spot lamp beside a sun, 2.3x less
    // variance in direct light and 1.56x less over 7 bounces, for ~10% more time per sample.
    bool auto_light_tree() const;
    // Whether every light is a lamp (point, spot, directional: no emitter, no environment) and
    // there are at most kLampChoiceMax of them: what light_by_contribution needs.
    static constexpr size_t kLampChoiceMax = 8;  // = LIGHT_CONTRIBUTION_MAX (gpu_scene.cpp)
    bool lamp_choice_possible() const;
    // --light-sampling auto (and the C API): sets light_by_contribution where
    // auto_light_by_contribution(), else light_tree where auto_light_tree().
    void choose_lights_automatically();
    // --light-sampling auto: by contribution wherever it is possible with two lamps or more.
    // Measured (PoCL, docs/lights.md): three Blender lamps, 4x less variance per sample than
    // the tree for 7% more time per sample.
    bool auto_light_by_contribution() const;

    uint32_t add_material(const Material& m) {
        materials.push_back(m);
        return static_cast<uint32_t>(materials.size() - 1);
    }
    Bounds bounds() const;
};

struct ValidationReport {
    size_t degenerate_dropped = 0;  // zero-area or collinear triangles removed
};

// A texture from 8-bit RGBA texels (row 0 first); sRGB-encoded color channels are decoded to
// linear (alpha never is).
Texture texture_from_rgba8(const std::string& name, int width, int height,
                           const unsigned char* rgba8, bool srgb);

// Checks a scene before rendering: throws mcpt::Error on non-finite vertices, bad material
// indices or an empty scene; drops degenerate triangles and counts them. (A scene may get its
// light afterwards, an environment: check_lit() says whether it has any.)
ValidationReport validate_scene(Scene& scene);

// Throws mcpt::Error naming the ways to light a scene when it has no light: no emissive
// triangle or sphere, no punctual light and no environment.
void check_lit(const Scene& scene);

// Points the camera at the scene bounds from the +z side (used when a file has no camera).
void frame_camera(Scene& scene);

}  // namespace mcpt
