// The glTF loader's materials and textures (gltf_loader_internal.h): each glTF material as a
// scene material (the mapping: gltf_loader.cpp's opening comment), its extensions' layers and
// volume, its textures decoded once per (texture, colour space), and KHR_texture_transform.
#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "common/io/texture_image.h"
#include "common/scene/gltf_loader_internal.h"

namespace mcpt {
namespace gltf {
namespace {

// Decoded textures in all (texels) at most: 2^26, 512 MiB as halves.
constexpr uint64_t kMaxTexels = uint64_t(1) << 26;

// glTF sampler wrap codes.
TextureWrap texture_wrap(int code) {
    switch (code) {
        case TINYGLTF_TEXTURE_WRAP_CLAMP_TO_EDGE:
            return TextureWrap::Clamp;
        case TINYGLTF_TEXTURE_WRAP_MIRRORED_REPEAT:
            return TextureWrap::Mirror;
        default:
            return TextureWrap::Repeat;
    }
}

// A number inside a material extension object, or `fallback`.
double extension_number(const tg::ExtensionMap& ext, const char* name, const char* key,
                        double fallback) {
    const auto it = ext.find(name);
    if (it == ext.end() || !it->second.Has(key)) return fallback;
    const tg::Value& v = it->second.Get(key);
    return v.IsNumber() ? v.GetNumberAsDouble() : fallback;
}

// The mean of KHR_materials_specular's specularColorFactor (1 when absent or malformed).
double specular_color_mean(const tg::ExtensionMap& ext) {
    const auto it = ext.find(kSpecular);
    if (it == ext.end() || !it->second.Has("specularColorFactor")) return 1.0;
    const tg::Value& c = it->second.Get("specularColorFactor");
    if (!c.IsArray() || c.ArrayLen() != 3) return 1.0;
    double sum = 0;
    for (int k = 0; k < 3; ++k) {
        const tg::Value& v = c.Get(k);
        if (!v.IsNumber() || !(v.GetNumberAsDouble() >= 0)) return 1.0;
        sum += v.GetNumberAsDouble();
    }
    return sum / 3;
}

glm::vec3 rgb(const std::vector<double>& v, float fallback) {
    if (v.size() < 3) return glm::vec3(fallback);
    return glm::vec3(float(v[0]), float(v[1]), float(v[2]));
}

// A number of a material extension in [0, 1] (`fallback` when absent).
double unit_number(const tg::Value& ext, const char* key, double fallback,
                   const std::string& label) {
    if (!ext.Has(key)) return fallback;
    const tg::Value& v = ext.Get(key);
    if (!v.IsNumber() || !(v.GetNumberAsDouble() >= 0) || !(v.GetNumberAsDouble() <= 1))
        throw std::invalid_argument(label + ": '" + key + "' must be a number in [0, 1]");
    return v.GetNumberAsDouble();
}

// A textureInfo inside a material extension: index (-1: none), texCoord, its extensions.
struct ExtensionTexture {
    int index = -1, tex_coord = 0;
    tg::ExtensionMap extensions;
};
ExtensionTexture extension_texture(const tg::Value& ext, const char* key,
                                   const std::string& label) {
    ExtensionTexture t;
    if (!ext.Has(key)) return t;
    const tg::Value& v = ext.Get(key);
    const auto index_of = [&](const char* name, int fallback) {
        if (!v.Has(name)) return fallback;
        const tg::Value& i = v.Get(name);
        if (!i.IsInt() || i.GetNumberAsInt() < 0)
            throw std::invalid_argument(label + ": " + key + "." + name + " must be an index >= 0");
        return i.GetNumberAsInt();
    };
    if (!v.IsObject() || !v.Has("index"))
        throw std::invalid_argument(label + ": '" + key + "' must be an object with an index");
    t.index = index_of("index", -1);
    t.tex_coord = index_of("texCoord", 0);
    if (v.Has("extensions") && v.Get("extensions").IsObject())
        for (const std::string& name : v.Get("extensions").Keys())
            t.extensions[name] = v.Get("extensions").Get(name);
    return t;
}

// KHR_materials_clearcoat and KHR_materials_sheen: factors in [0, 1] and their textures (the

}  // namespace

// One scene material per glTF material, same index.
void GltfLoader::convert_materials() {
    for (size_t i = 0; i < model_.materials.size(); ++i) {
        const tg::Material& g = model_.materials[i];
        const tg::PbrMetallicRoughness& pbr = g.pbrMetallicRoughness;
        Material m;
        m.name = g.name.empty() ? "material " + std::to_string(i) : g.name;
        m.color = rgb(pbr.baseColorFactor, 1.f);
        // Emission scaled by KHR_materials_emissive_strength.
        const double strength =
            extension_number(g.extensions, kEmissiveStrength, "emissiveStrength", 1.0);
        m.emission = rgb(g.emissiveFactor, 0.f) * float(strength);
        m.two_sided = g.doubleSided;
        // Glass, mirror, diffuse or metallic-roughness.
        m.ior = float(extension_number(g.extensions, kIor, "ior", 1.5));
        m.metallic = float(pbr.metallicFactor);
        m.roughness = float(pbr.roughnessFactor);
        // KHR_materials_specular: specularFactor times specularColorFactor, the colour taken
        // as its mean (a scalar layer; Blender writes [0, 0, 0] for Specular 0).
        m.specular = float(extension_number(g.extensions, kSpecular, "specularFactor", 1.0) *
                           specular_color_mean(g.extensions));
        // Textures (texture coordinates 0), color ones sRGB-decoded, each placed by its
        // KHR_texture_transform.
        const std::string what = "material '" + m.name + "'";
        MaterialUv uv(what);
        m.tex_base = uv.slot(*this, pbr.baseColorTexture.index, pbr.baseColorTexture.texCoord,
                             pbr.baseColorTexture.extensions, true, "baseColorTexture");
        m.tex_metal_rough = uv.slot(
            *this, pbr.metallicRoughnessTexture.index, pbr.metallicRoughnessTexture.texCoord,
            pbr.metallicRoughnessTexture.extensions, false, "metallicRoughnessTexture");
        m.tex_normal = uv.slot(*this, g.normalTexture.index, g.normalTexture.texCoord,
                               g.normalTexture.extensions, false, "normalTexture");
        m.tex_emission = uv.slot(*this, g.emissiveTexture.index, g.emissiveTexture.texCoord,
                                 g.emissiveTexture.extensions, true, "emissiveTexture");
        material_layers(g.extensions, m, uv, what);
        uv_transforms_.push_back(uv.transform(*this));
        // alphaMode MASK: the cutoff against texture alpha, the factor folded in.
        if (g.alphaMode == "MASK" && g.alphaCutoff > 0.0) {
            const double factor = pbr.baseColorFactor.size() == 4 ? pbr.baseColorFactor[3] : 1.0;
            m.alpha_cutoff = factor > 0.0 ? float(g.alphaCutoff / factor)
                                          : std::numeric_limits<float>::infinity();
        }
        if (extension_number(g.extensions, kTransmission, "transmissionFactor", 0.0) > 0.5) {
            // Smooth glass is the limit of roughness 0, traced exactly.
            m.type = pbr.roughnessFactor <= 0.01 ? MaterialType::Glass : MaterialType::RoughGlass;
        } else if (m.has_clearcoat() || m.has_sheen()) {
            m.type = MaterialType::Pbr;  // layers over metallic-roughness
        } else if (pbr.metallicFactor >= 1.0 && pbr.roughnessFactor <= 0.01 &&
                   m.tex_metal_rough < 0) {
            m.type = MaterialType::Mirror;  // the limit of roughness 0, traced exactly
        } else if (pbr.metallicFactor <= 0.0 && m.specular <= 0.f) {
            m.type = MaterialType::Diffuse;  // no specular layer: exactly Lambertian
        } else {
            m.type = MaterialType::Pbr;
        }
        m.absorption = volume_absorption(g.extensions, m, what);
        scene_.add_material(m);
    }
}

// coat's normal texture is not read: the coat takes the base's shading normal).
void GltfLoader::material_layers(const tg::ExtensionMap& ext, Material& m, MaterialUv& uv,
                                 const std::string& what) {
    const auto texture = [&](const tg::Value& x, const char* key, bool srgb,
                             const std::string& label) {
        const ExtensionTexture t = extension_texture(x, key, label);
        return uv.slot(*this, t.index, t.tex_coord, t.extensions, srgb, key);
    };
    try {
        if (const auto it = ext.find(kClearcoat); it != ext.end() && it->second.IsObject()) {
            const tg::Value& x = it->second;
            const std::string label = what + " " + kClearcoat;
            m.clearcoat = float(unit_number(x, "clearcoatFactor", 0.0, label));
            m.clearcoat_roughness = float(unit_number(x, "clearcoatRoughnessFactor", 0.0, label));
            if (m.clearcoat > 0.f) {
                m.tex_clearcoat = texture(x, "clearcoatTexture", false, label);
                m.tex_clearcoat_roughness = texture(x, "clearcoatRoughnessTexture", false, label);
                if (x.Has("clearcoatNormalTexture"))
                    warn_once("coat normal",
                              "clearcoatNormalTexture is not used (the coat "
                              "takes the base's normal), e.g. " +
                                  what);
            }
        }
        if (const auto it = ext.find(kSheen); it != ext.end() && it->second.IsObject()) {
            const tg::Value& x = it->second;
            const std::string label = what + " " + kSheen;
            if (x.Has("sheenColorFactor")) {
                const tg::Value& c = x.Get("sheenColorFactor");
                if (!c.IsArray() || c.ArrayLen() != 3)
                    fail(label + ": 'sheenColorFactor' must be three numbers in [0, 1]");
                for (int k = 0; k < 3; ++k) {
                    const tg::Value& v = c.Get(k);
                    if (!v.IsNumber() || !(v.GetNumberAsDouble() >= 0) ||
                        !(v.GetNumberAsDouble() <= 1))
                        fail(label + ": 'sheenColorFactor' must be three numbers in [0, 1]");
                    m.sheen_color[k] = float(v.GetNumberAsDouble());
                }
            }
            m.sheen_roughness = float(unit_number(x, "sheenRoughnessFactor", 0.0, label));
            if (m.has_sheen()) {
                m.tex_sheen_color = texture(x, "sheenColorTexture", true, label);
                m.tex_sheen_roughness = texture(x, "sheenRoughnessTexture", false, label);
            }
        }
    } catch (const std::invalid_argument& e) {
        fail(e.what());
    }
}

// KHR_materials_volume on glass that is not thin-walled (thicknessFactor > 0): Beer-Lambert
// absorption -ln(attenuationColor) / attenuationDistance per unit length (scene units, as the
// node transforms scale them: a mesh scaled up absorbs more). thicknessFactor itself is for
// rasterizers and is not used. 0 where the material is clear or thin-walled.
glm::vec3 GltfLoader::volume_absorption(const tg::ExtensionMap& ext, const Material& m,
                                        const std::string& what) {
    const auto it = ext.find(kVolume);
    if (it == ext.end()) return glm::vec3(0.f);
    if (m.type != MaterialType::Glass && m.type != MaterialType::RoughGlass) {
        warn_once("volume:" + what,
                  what + ": " + kVolume + " without KHR_materials_transmission; ignored");
        return glm::vec3(0.f);
    }
    const double thickness = extension_number(ext, kVolume, "thicknessFactor", 0.0);
    const double distance = extension_number(ext, kVolume, "attenuationDistance", HUGE_VAL);
    if (!(thickness >= 0) || !(distance > 0))
        fail(what + " " + kVolume + ": thicknessFactor must be >= 0 and attenuationDistance > 0");
    glm::dvec3 color(1.0);
    if (it->second.Has("attenuationColor")) {
        const tg::Value& c = it->second.Get("attenuationColor");
        if (!c.IsArray() || c.ArrayLen() != 3)
            fail(what + " " + kVolume + ": attenuationColor must be three numbers");
        for (int k = 0; k < 3; ++k) {
            if (!c.Get(k).IsNumber() || !(c.Get(k).GetNumberAsDouble() >= 0) ||
                !(c.Get(k).GetNumberAsDouble() <= 1))
                fail(what + " " + kVolume + ": attenuationColor must be in [0, 1]");
            color[k] = c.Get(k).GetNumberAsDouble();
        }
    }
    if (thickness == 0 || std::isinf(distance)) return glm::vec3(0.f);  // thin-walled, clear
    // A channel of colour 0 absorbs everything: as good as a coefficient of 1e30 per unit.
    glm::vec3 sigma;
    for (int k = 0; k < 3; ++k)
        sigma[k] = float(std::min(1e30, -std::log(std::max(color[k], 1e-300)) / distance));
    return sigma;
}

uint32_t GltfLoader::material_index(int material, const std::string& where) {
    if (material >= 0 && size_t(material) < model_.materials.size()) return uint32_t(material);
    if (material != -1)
        fail(where + ": material index " + std::to_string(material) + " out of range (file has " +
             std::to_string(model_.materials.size()) + " materials)");
    // No material: a shared grey diffuse one.
    if (default_material_ < 0) {
        Material m;
        m.name = "default";
        m.color = glm::vec3(0.8f);
        default_material_ = int(scene_.add_material(m));
    }
    return uint32_t(default_material_);
}

// KHR_texture_transform of a texture slot as the matrix glTF gives, T * R * S (identity when
// absent); its texCoord, where given, replaces the slot's.
glm::dmat3 GltfLoader::texture_transform(const tg::ExtensionMap& ext, int& tex_coord,
                                         const std::string& what) const {
    const auto it = ext.find(kTextureTransform);
    if (it == ext.end() || !it->second.IsObject()) return glm::dmat3(1.0);
    const tg::Value& x = it->second;
    const std::string label = what + " " + kTextureTransform;
    // A member of n finite numbers (defaults when absent).
    const auto numbers = [&](const char* key, glm::dvec2 fallback) {
        if (!x.Has(key)) return fallback;
        const tg::Value& v = x.Get(key);
        glm::dvec2 out = fallback;
        if (v.IsNumber() && std::string(key) == "rotation") {
            out.x = v.GetNumberAsDouble();
        } else if (v.IsArray() && v.ArrayLen() == 2 && v.Get(0).IsNumber() && v.Get(1).IsNumber()) {
            out = glm::dvec2(v.Get(0).GetNumberAsDouble(), v.Get(1).GetNumberAsDouble());
        } else {
            fail(label + ": '" + key + "' must be " +
                 (std::string(key) == "rotation" ? "a number" : "two numbers"));
        }
        if (!std::isfinite(out.x) || !std::isfinite(out.y))
            fail(label + ": '" + key + "' must be finite");
        return out;
    };
    const glm::dvec2 offset = numbers("offset", glm::dvec2(0.0));
    const double rotation = numbers("rotation", glm::dvec2(0.0)).x;
    const glm::dvec2 scale = numbers("scale", glm::dvec2(1.0));
    if (x.Has("texCoord")) {
        if (!x.Get("texCoord").IsInt() || x.Get("texCoord").GetNumberAsInt() < 0)
            fail(label + ": 'texCoord' must be an index >= 0");
        tex_coord = x.Get("texCoord").GetNumberAsInt();
    }
    // uv' = T * R * S * uv (column-major): u' = cos sx u + sin sy v + ox,
    // v' = -sin sx u + cos sy v + oy.
    const double c = std::cos(rotation), s = std::sin(rotation);
    return glm::dmat3(glm::dvec3(c * scale.x, -s * scale.x, 0.0),
                      glm::dvec3(s * scale.y, c * scale.y, 0.0),
                      glm::dvec3(offset.x, offset.y, 1.0));
}

// The scene texture of glTF texture `texture` decoded as sRGB color or linear data (each pair
// decoded once); -1 for none.
int GltfLoader::texture_for(int texture, int tex_coord, bool srgb, const std::string& what) {
    if (texture < 0) return -1;
    if (size_t(texture) >= model_.textures.size())
        fail(what + ": texture " + std::to_string(texture) + " out of range (file has " +
             std::to_string(model_.textures.size()) + " textures)");
    if (tex_coord != 0) {
        warn_once("texcoord", "only texture coordinates 0 are supported; " + what + " ignored");
        return -1;
    }
    const auto cached = textures_.find({texture, srgb});
    if (cached != textures_.end()) return cached->second;
    const tg::Texture& t = model_.textures[size_t(texture)];
    const int source = texture_source(t, what);
    if (source < 0) return -1;
    const auto bytes = image_bytes_.find(source);
    if (bytes == image_bytes_.end() || bytes->second.empty()) {
        const std::string& uri = model_.images[size_t(source)].uri;
        fail(what + ": image " + std::to_string(source) + " has no data" +
             (uri.empty() || uri.rfind("data:", 0) == 0
                  ? std::string()
                  : " (file '" + uri + "' missing, unreadable or outside the scene's folder)"));
    }
    // Decode to 8-bit RGBA (the size checked before any texel is allocated).
    const std::vector<unsigned char>& b = bytes->second;
    const std::string image_what = what + ": image " + std::to_string(source);
    TextureImageInfo info;
    std::vector<unsigned char> rgba;
    try {
        info = texture_image_info(b.data(), b.size());
        const int w = info.width, h = info.height;
        if (w <= 0 || h <= 0 || w > 16384 || h > 16384 ||
            texels_ + uint64_t(w) * uint64_t(h) > kMaxTexels)
            fail(image_what + " of " + std::to_string(w) + "x" + std::to_string(h) +
                 " texels exceeds 16384x16384, or 64 M texels in all");
        rgba = decode_texture_image(b.data(), b.size(), info);
    } catch (const Error& e) {
        if (std::string(e.what()).rfind(path_, 0) == 0) throw;  // already ours
        fail(image_what + ": " + e.what());
    }
    const int w = info.width, h = info.height;
    const tg::Image& image = model_.images[size_t(source)];
    Texture tex =
        texture_from_rgba8(image.name.empty() ? image.uri : image.name, w, h, rgba.data(), srgb);
    texels_ += uint64_t(w) * uint64_t(h);
    // Wrap modes and magnification filter from its sampler.
    if (t.sampler >= 0 && size_t(t.sampler) < model_.samplers.size()) {
        const tg::Sampler& smp = model_.samplers[size_t(t.sampler)];
        tex.wrap_s = texture_wrap(smp.wrapS);
        tex.wrap_t = texture_wrap(smp.wrapT);
        tex.nearest = smp.magFilter == TINYGLTF_TEXTURE_FILTER_NEAREST;
    }
    scene_.textures.push_back(std::move(tex));
    const int index = int(scene_.textures.size() - 1);
    textures_[{texture, srgb}] = index;
    return index;
}

// The image a texture shows: EXT_texture_webp's source, else its own (PNG or JPEG; the
// fallback of KHR_texture_basisu, whose KTX2 image is not decoded); -1 (warned) for none.
int GltfLoader::texture_source(const tg::Texture& t, const std::string& what) {
    int source = t.source;
    const auto webp = t.extensions.find(kTextureWebp);
    if (webp != t.extensions.end() && webp->second.Has("source") && has_webp_decoder()) {
        const tg::Value& v = webp->second.Get("source");
        if (!v.IsInt()) fail(what + ": " + kTextureWebp + " source must be an image index");
        source = v.GetNumberAsInt();
    }
    if (source < 0 && t.extensions.count(kTextureBasisu)) {
        warn_once("basisu", what + ": only a KTX2 image (" + kTextureBasisu +
                                ", not decoded: no KTX2 decoder is packaged for Debian 12); "
                                "texture ignored");
        return -1;
    }
    if (source < 0) {
        warn_once("texsource", what + ": texture without an image; ignored");
        return -1;
    }
    if (size_t(source) >= model_.images.size())
        fail(what + ": image " + std::to_string(source) + " out of range (file has " +
             std::to_string(model_.images.size()) + " images)");
    return source;
}

}  // namespace gltf
}  // namespace mcpt
