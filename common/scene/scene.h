// The scene model shared by every backend: triangles and spheres in world space, materials,
// and a pinhole camera. Loaders fill it; validate_scene() checks it; the k-d tree builder and
// the GPU packer (gpu_scene.h) read it.
#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include <glm/glm.hpp>

namespace mcpt {

// Pbr: glTF metallic-roughness (GGX specular over a diffuse base, blended with a GGX metal).
// RoughGlass: a rough dielectric (GGX reflection and refraction, roughness and ior).
enum class MaterialType : uint32_t { Diffuse = 0, Mirror = 1, Glass = 2, Pbr = 3, RoughGlass = 4 };

struct Material {
    std::string name;
    MaterialType type = MaterialType::Diffuse;
    glm::vec3 color{0.8f};    // diffuse albedo, mirror tint or glass transmission tint
    glm::vec3 emission{0.f};  // emitted radiance; front side of triangles, outside of spheres
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
    Camera camera;
    bool has_camera = false;  // false: frame the scene bounds automatically
    int max_depth_hint = 0;   // > 0: a bounce limit the scene asks for (0: the renderer's default)
    std::vector<std::string> warnings;  // unsupported features met while loading

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
// indices, an empty scene or no emitter; drops degenerate triangles and counts them.
ValidationReport validate_scene(Scene& scene);

// Points the camera at the scene bounds from the +z side (used when a file has no camera).
void frame_camera(Scene& scene);

}  // namespace mcpt
