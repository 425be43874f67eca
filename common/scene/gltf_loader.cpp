// glTF 2.0 loader (tinygltf): the default scene's node hierarchy, triangle meshes flattened to
// world space, the first perspective camera, and materials mapped as follows.
//
// glTF material mapping:
//   emission = emissiveFactor * KHR_materials_emissive_strength.emissiveStrength (default 1);
//              the front side of a triangle emits (counter-clockwise seen from the front,
//              clockwise under a mirroring node transform, as glTF defines it), and the back
//              too where the material is doubleSided (as glTF viewers and Cycles render it).
//   KHR_materials_transmission.transmissionFactor > 0.5
//       -> Glass (roughnessFactor <= 0.01) or RoughGlass, ior = KHR_materials_ior.ior
//          (default 1.5), color = baseColorFactor.rgb
//   otherwise metallicFactor = 1 and roughnessFactor <= 0.01
//       -> Mirror, color = baseColorFactor.rgb (the limit of roughness 0, traced exactly)
//   otherwise metallicFactor = 0 and KHR_materials_specular specularFactor *
//   mean(specularColorFactor) = 0
//       -> Diffuse, color = baseColorFactor.rgb (no specular layer: exactly Lambertian)
//   otherwise
//       -> Pbr: glTF's metallic-roughness BRDF (gpu/microfacet.h) with baseColorFactor,
//          metallicFactor, roughnessFactor, KHR_materials_ior.ior and
//          KHR_materials_specular.specularFactor (default 1).
//   KHR_materials_volume on glass (thicknessFactor > 0): Beer-Lambert absorption inside,
//   -ln(attenuationColor) / attenuationDistance per unit length.
//   KHR_materials_clearcoat and KHR_materials_sheen (factors and textures) make a material
//   Pbr with those layers (gpu/layers.h); on glass they are not read.
//   A primitive without a material gets a grey (0.8) Diffuse material.
// Lamps (KHR_lights_punctual) on nodes: point, spot and directional lights at the node's
// world transform (position; direction -Z), color * intensity / 683 lm/W (candela to W/sr,
// lux to W/m^2, as Blender's importer converts them), range and cone angles as glTF says.
// Textures: base color, metallic-roughness, normal and emissive (texture coordinates 0), PNG
// and JPEG (stb_image), WebP (EXT_texture_webp, libwebp), each placed by its material's
// KHR_texture_transform (baked into the triangles' texture coordinates); alphaMode MASK.
// Meshes as optimizing pipelines ship them: KHR_mesh_quantization (integer and normalized
// attributes; the node transform undoes the scale), EXT_meshopt_compression and
// KHR_draco_mesh_compression (gltf_compression.h), decoded before any check.
//   Ignored with a warning: occlusion textures, texture coordinates other than 0, skins,
//   animations, morph targets, non-perspective cameras, primitive modes other than TRIANGLES,
//   KHR_texture_basisu (KTX2: its PNG/JPEG/WebP fallback is used where the file has one) and
//   the other extensions. A file that requires (extensionsRequired) any other extension is
//   rejected, naming it.

#include "common/scene/gltf_loader.h"

// tinygltf (its implementation: tinygltf_impl.cpp) hands images over undecoded (its image
// callback keeps the bytes); the loader decodes the ones materials use (texture_image.h).
#include <algorithm>
#include <cctype>
#include <cfloat>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <glm/gtc/constants.hpp>
#include <glm/gtc/matrix_transform.hpp>
#include <glm/gtc/quaternion.hpp>
#include <glm/gtc/type_ptr.hpp>
#include <iterator>
#include <limits>
#include <map>
#include <set>
#include <sstream>
#include <stdexcept>
#include <utility>

#include "common/error.h"
#include "common/io/host_memory.h"
#include "common/io/texture_image.h"
#include "common/scene/gltf_compression.h"
#include "common/scene/tinygltf.h"

namespace mcpt {
namespace {

namespace tg = tinygltf;

const char* const kEmissiveStrength = "KHR_materials_emissive_strength";
const char* const kTransmission = "KHR_materials_transmission";
const char* const kIor = "KHR_materials_ior";
const char* const kSpecular = "KHR_materials_specular";
const char* const kVolume = "KHR_materials_volume";
const char* const kClearcoat = "KHR_materials_clearcoat";
const char* const kSheen = "KHR_materials_sheen";

const char* const kLightsPunctual = "KHR_lights_punctual";
const char* const kQuantization = "KHR_mesh_quantization";
const char* const kTextureTransform = "KHR_texture_transform";
const char* const kTextureWebp = "EXT_texture_webp";
const char* const kTextureBasisu = "KHR_texture_basisu";

// Extensions the loader reads (the decoders only where this build has their libraries).
bool supported_extension(const std::string& name) {
    return name == kEmissiveStrength || name == kTransmission || name == kIor ||
           name == kSpecular || name == kVolume || name == kClearcoat || name == kSheen ||
           name == kLightsPunctual || name == kQuantization || name == kTextureTransform ||
           (name == kTextureWebp && has_webp_decoder()) ||
           (name == kMeshoptCompression && GltfCompression::has_meshopt()) ||
           (name == kDracoCompression && GltfCompression::has_draco());
}

// What to do about a required extension the loader lacks, where there is something to say.
std::string unsupported_advice(const std::string& name) {
    if (name == kTextureBasisu)
        return " (KTX2 textures: no KTX2 decoder is packaged for Debian 12; export PNG, JPEG "
               "or WebP textures instead: gltfpack without -tc, gltf-transform without "
               "etc1s/uastc)";
    if (name == kTextureWebp) return " (this build has no WebP decoder: libwebp-dev)";
    if (name == kMeshoptCompression)
        return " (this build has no meshoptimizer: libmeshoptimizer-dev)";
    if (name == kDracoCompression) return " (this build has no Draco decoder: libdraco-dev)";
    return "";
}

// glTF's photometric units to radiometric ones: 683 lm/W, as Blender's glTF importer.
constexpr double kLumensPerWatt = 683.0;

// The JSON parser recurses once per nesting level: a file nesting arrays tens of thousands
// deep would overflow the stack. glTF itself nests a handful of levels; extras may add some.
constexpr int kMaxJsonDepth = 256;

// Elements of an accessor without a bufferView (zeros but for its sparse values): 2^24, 192 MiB
// as positions; no real scene comes near it without data behind it.
constexpr size_t kMaxZeroAccessorCount = size_t(1) << 24;

// The deepest nesting of arrays and objects in JSON text (brackets inside strings do not
// count), stopping once it exceeds kMaxJsonDepth.
int json_depth(const char* p, size_t n) {
    int depth = 0, deepest = 0;
    bool in_string = false;
    for (size_t i = 0; i < n && deepest <= kMaxJsonDepth; ++i) {
        const char c = p[i];
        if (in_string) {
            if (c == '\\')
                ++i;  // skip the escaped character
            else if (c == '"')
                in_string = false;
        } else if (c == '"') {
            in_string = true;
        } else if (c == '[' || c == '{') {
            deepest = std::max(deepest, ++depth);
        } else if (c == ']' || c == '}') {
            --depth;
        }
    }
    return deepest;
}

// The JSON text of a .gltf (all of it) or a .glb (its first chunk, when the header is whole).
std::pair<const char*, size_t> json_text(const unsigned char* bytes, size_t size, bool binary) {
    if (!binary) return {reinterpret_cast<const char*>(bytes), size};
    if (size < 20) return {nullptr, 0};
    uint32_t length = 0;
    std::memcpy(&length, bytes + 12, 4);
    return {reinterpret_cast<const char*>(bytes) + 20, std::min<size_t>(length, size - 20)};
}

// The .glb container's layout, checked before tinygltf reads it (tinygltf 2.8 lets a BIN chunk
// run 8 bytes past the file: it forgets the chunk's own header). "" when whole.
std::string glb_layout_error(const unsigned char* bytes, size_t size) {
    if (size < 20) return "GLB shorter than its 20-byte header";
    uint32_t word[5];
    std::memcpy(word, bytes, sizeof word);  // magic, version, length, JSON length, JSON type
    if (word[1] != 2) return "GLB version " + std::to_string(word[1]) + " (glTF 2.0 needs 2)";
    const uint64_t length = word[2], json_end = 20 + uint64_t(word[3]);
    if (length > size)
        return "GLB header says " + std::to_string(length) + " bytes, the data has " +
               std::to_string(size);
    if (word[4] != 0x4E4F534Au) return "GLB's first chunk is not JSON";
    if (json_end > length) return "GLB JSON chunk runs past the end of the file";
    if (json_end == length) return "";
    if (json_end + 8 > length) return "GLB BIN chunk header runs past the end of the file";
    uint32_t bin_length = 0;
    std::memcpy(&bin_length, bytes + json_end, 4);
    if (json_end + 8 + bin_length > length)
        return "GLB BIN chunk of " + std::to_string(bin_length) + " bytes runs past the end of " +
               "the file (" + std::to_string(length) + " bytes)";
    return "";
}

// External files (buffer and image URIs) come only from the scene's own folder: a regular
// file below it, at most kMaxExternalBytes; never a FIFO or device (they block forever), never
// a path that leaves the folder (absolute, "../"), and never a message about such a file's
// size or contents.
constexpr uint64_t kMaxExternalBytes = uint64_t(2) << 30;

struct FolderFs {
    std::filesystem::path root;  // canonical

    // The canonical path of `p` if it lies inside root, else empty.
    std::filesystem::path inside(const std::string& p) const {
        std::error_code ec;
        const std::filesystem::path c = std::filesystem::weakly_canonical(p, ec);
        if (ec) return {};
        const std::string r = root.string(), s = c.string();
        if (s.size() <= r.size() || s.compare(0, r.size(), r) != 0 ||
            (r.back() != '/' && s[r.size()] != '/'))
            return {};
        return c;
    }
};

tg::FsCallbacks folder_callbacks(const FolderFs* fs) {
    tg::FsCallbacks cb{};
    cb.user_data = const_cast<FolderFs*>(fs);
    cb.ExpandFilePath = [](const std::string& p, void*) { return p; };  // no "~" expansion
    // Existence is ReadWholeFile's to judge, so that a refusal says why.
    cb.FileExists = [](const std::string&, void*) { return true; };
    cb.ReadWholeFile = [](std::vector<unsigned char>* out, std::string* err, const std::string& p,
                          void* ud) {
        const FolderFs* fs = static_cast<FolderFs*>(ud);
        const std::filesystem::path c = fs->inside(p);
        std::error_code ec;
        const std::string name = std::filesystem::path(p).filename().string();
        std::string why;
        if (c.empty()) {
            why = "outside the scene's folder " + fs->root.string();
        } else if (!std::filesystem::exists(c, ec)) {
            why = "not found";
        } else if (!std::filesystem::is_regular_file(c, ec)) {
            why = "not a regular file";
        } else if (std::filesystem::file_size(c, ec) > kMaxExternalBytes || ec) {
            why = "larger than 2 GiB";
        } else {
            std::ifstream in(c, std::ios::binary);
            out->assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
            if (in.bad()) why = "cannot be read";
        }
        if (why.empty()) return true;
        if (err) *err += "external file '" + name + "' refused: " + why + "\n";
        return false;
    };
    cb.WriteWholeFile = [](std::string* err, const std::string&, const std::vector<unsigned char>&,
                           void*) {
        if (err) *err += "writing is not allowed\n";
        return false;
    };
    return cb;
}

// Image callback that keeps each image's encoded bytes (user_data: the map to keep them in).
using ImageBytes = std::map<int, std::vector<unsigned char>>;
bool keep_image(tg::Image*, const int index, std::string*, std::string*, int, int,
                const unsigned char* bytes, int size, void* user_data) {
    if (bytes && size > 0)
        (*static_cast<ImageBytes*>(user_data))[index].assign(bytes, bytes + size);
    return true;
}

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

std::string mode_name(int mode) {
    switch (mode) {
        case TINYGLTF_MODE_POINTS:
            return "POINTS";
        case TINYGLTF_MODE_LINE:
            return "LINES";
        case TINYGLTF_MODE_LINE_LOOP:
            return "LINE_LOOP";
        case TINYGLTF_MODE_LINE_STRIP:
            return "LINE_STRIP";
        case TINYGLTF_MODE_TRIANGLE_STRIP:
            return "TRIANGLE_STRIP";
        case TINYGLTF_MODE_TRIANGLE_FAN:
            return "TRIANGLE_FAN";
        default:
            return std::to_string(mode);
    }
}

std::string trim_trailing_space(std::string s) {
    while (!s.empty() && std::isspace(static_cast<unsigned char>(s.back()))) s.pop_back();
    return s;
}

// Size in bytes of an index component type, 0 for anything else.
size_t index_size(int component_type) {
    switch (component_type) {
        case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE:
            return 1;
        case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT:
            return 2;
        case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT:
            return 4;
        default:
            return 0;
    }
}

// Size in bytes of a float or 8-/16-/32-bit integer component, 0 for anything else.
size_t component_size(int component_type) {
    switch (component_type) {
        case TINYGLTF_COMPONENT_TYPE_BYTE:
        case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE:
            return 1;
        case TINYGLTF_COMPONENT_TYPE_SHORT:
        case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT:
            return 2;
        case TINYGLTF_COMPONENT_TYPE_FLOAT:
        case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT:
            return 4;
        default:
            return 0;
    }
}

// One component as a float: normalized integers as glTF maps them (signed: max(c / (2^(n-1) -
// 1), -1); unsigned: c / (2^n - 1)), other integers as they are.
float component_value(const unsigned char* p, int type, bool normalized) {
    switch (type) {
        case TINYGLTF_COMPONENT_TYPE_BYTE: {
            const float c = float(int8_t(*p));
            return normalized ? std::max(c / 127.f, -1.f) : c;
        }
        case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE:
            return normalized ? float(*p) / 255.f : float(*p);
        case TINYGLTF_COMPONENT_TYPE_SHORT: {
            int16_t v;
            std::memcpy(&v, p, 2);
            return normalized ? std::max(float(v) / 32767.f, -1.f) : float(v);
        }
        case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: {
            uint16_t v;
            std::memcpy(&v, p, 2);
            return normalized ? float(v) / 65535.f : float(v);
        }
        case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT: {
            uint32_t v;
            std::memcpy(&v, p, 4);
            return normalized ? float(double(v) / 4294967295.0) : float(v);
        }
        default: {
            float v;
            std::memcpy(&v, p, 4);
            return v;
        }
    }
}

uint32_t read_index(const unsigned char* p, size_t size) {
    if (size == 1) return *p;
    if (size == 2) {
        uint16_t v;
        std::memcpy(&v, p, 2);
        return v;
    }
    uint32_t v;
    std::memcpy(&v, p, 4);
    return v;
}

class GltfLoader {
  public:
    // From a file; or from `bytes` in memory, named `path` in messages, whose external files
    // are read from base_dir (none when empty: the loader never touches the file system).
    explicit GltfLoader(std::string path) : path_(std::move(path)) {}
    GltfLoader(std::string name, const unsigned char* bytes, size_t size, std::string base_dir)
        : path_(std::move(name)),
          bytes_(bytes),
          size_(size),
          base_dir_(std::move(base_dir)),
          in_memory_(true) {}
    Scene load();

  private:
    [[noreturn]] void fail(const std::string& message) const {
        throw Error(path_ + ": " + message);
    }
    void warn_once(const std::string& key, const std::string& message) {
        if (warned_.insert(key).second) scene_.warnings.push_back(message);
    }
    void read_model();
    void check_features();
    void convert_materials();
    std::vector<int> root_nodes();
    void traverse(const std::vector<int>& roots);
    void check_triangle_budget(const std::vector<int>& roots) const;
    glm::dmat4 local_transform(const tg::Node& node, int index);
    void take_camera(int camera, const glm::dmat4& world);
    void add_light(int light, const glm::dmat4& world, int node);
    void add_mesh(int mesh, const glm::dmat4& world);
    uint32_t material_index(int material, const std::string& where);
    const unsigned char* view_data(int view, size_t offset, size_t count, size_t stride,
                                   size_t elem, const std::string& what) const;
    template <class T, class Decode>
    std::vector<T> read_accessor(const tg::Accessor& a, size_t elem, const std::string& what,
                                 Decode decode) const;
    const tg::Accessor& accessor_at(int accessor, const std::string& what) const;
    template <int N>
    std::vector<glm::vec<N, float>> read_vectors(const tg::Accessor& a,
                                                 const std::string& what) const;
    std::vector<glm::vec3> read_positions(int accessor, const std::string& where) const;
    std::vector<glm::vec3> read_normals(int accessor, const std::string& where) const;
    std::vector<glm::vec2> read_texcoords(int accessor, const std::string& where) const;
    int texture_for(int texture, int tex_coord, bool srgb, const std::string& what);
    int texture_source(const tg::Texture& t, const std::string& what);
    glm::vec3 volume_absorption(const tg::ExtensionMap& ext, const Material& m,
                                const std::string& what);
    class MaterialUv;
    void material_layers(const tg::ExtensionMap& ext, Material& m, MaterialUv& uv,
                         const std::string& what);
    glm::dmat3 texture_transform(const tg::ExtensionMap& ext, int& tex_coord,
                                 const std::string& what) const;

    // A material's texture slots and the one KHR_texture_transform baked into its triangles'
    // texture coordinates (the slots' own where they agree; else the base color's, warned).
    class MaterialUv {
      public:
        explicit MaterialUv(std::string what) : what_(std::move(what)) {}
        int slot(GltfLoader& loader, int texture, int tex_coord, const tg::ExtensionMap& ext,
                 bool srgb, const char* name) {
            const std::string what = what_ + " " + name;
            const glm::dmat3 t = loader.texture_transform(ext, tex_coord, what);
            const int index = loader.texture_for(texture, tex_coord, srgb, what);
            if (index >= 0) transforms_.emplace_back(name, t);
            return index;
        }
        glm::dmat3 transform(GltfLoader& loader) const {
            if (transforms_.empty()) return glm::dmat3(1.0);
            for (const auto& [name, t] : transforms_)
                if (t != transforms_[0].second)
                    loader.warn_once("uvt:" + what_,
                                     what_ + ": its textures' " + kTextureTransform + " differ; " +
                                         transforms_[0].first + "'s is applied to all of them");
            return transforms_[0].second;
        }

      private:
        std::string what_;
        std::vector<std::pair<std::string, glm::dmat3>> transforms_;
    };
    std::vector<uint32_t> read_indices(int accessor, const std::string& where) const;

    void parse_memory();
    void prepare_compressed(std::vector<unsigned char>& bytes, bool binary);
    void decode_compressed();

    std::string path_;
    const unsigned char* bytes_ = nullptr;
    size_t size_ = 0;
    std::string base_dir_;
    bool in_memory_ = false;
    tg::Model model_;
    Scene scene_;
    std::set<std::string> warned_;
    int default_material_ = -1;
    ImageBytes image_bytes_;
    GltfCompression compression_;                   // meshopt and Draco, set up and decoded
    std::vector<unsigned char> rewritten_;          // in-memory data as rewritten for tinygltf
    std::vector<glm::dmat3> uv_transforms_;         // per material: KHR_texture_transform
    std::map<std::pair<int, bool>, int> textures_;  // (glTF texture, sRGB) -> scene texture
    uint64_t texels_ = 0;
};

Scene GltfLoader::load() {
    read_model();
    try {
        // Whole-file checks and warnings, then materials, then the node hierarchy.
        check_features();
        convert_materials();
        const std::vector<int> roots = root_nodes();
        check_triangle_budget(roots);
        traverse(roots);
    } catch (const Error&) {
        throw;
    } catch (const std::exception& e) {
        fail(std::string("cannot convert the glTF model: ") + e.what());
    }
    // No camera in the file: frame the geometry.
    if (!scene_.has_camera) frame_camera(scene_);
    return std::move(scene_);
}

// Reads and parses the file with tinygltf (binary if it starts with the GLB magic).
void GltfLoader::read_model() {
    if (in_memory_) return parse_memory();
    std::error_code ec;
    if (!std::filesystem::exists(path_, ec)) fail("file not found");
    if (std::filesystem::is_directory(path_, ec)) fail("is a directory, not a glTF file");
    std::ifstream in(path_, std::ios::binary);
    if (!in) fail("cannot open file");
    char magic[4] = {};
    in.read(magic, 4);
    const bool binary = in.gcount() == 4 && std::memcmp(magic, "glTF", 4) == 0;
    // The whole file, then its layout, then its JSON's nesting (bounded before the parser
    // recurses through it).
    const uint64_t file_size = std::filesystem::file_size(path_, ec);
    if (ec) fail("cannot read file size");
    if (file_size == 0) fail("empty file (0 bytes): not a glTF file");
    if (file_size > 0xffffffffu) fail("file larger than 4 GiB");
    std::vector<unsigned char> bytes(file_size);
    in.clear();  // a file shorter than the magic ended the first read
    in.seekg(0);
    if (!in.read(reinterpret_cast<char*>(bytes.data()), std::streamsize(file_size)))
        fail("cannot read file");
    in.close();
    if (binary) {
        const std::string layout = glb_layout_error(bytes.data(), bytes.size());
        if (!layout.empty()) fail("cannot load binary glTF (.glb) file: " + layout);
    }
    const auto [text, length] = json_text(bytes.data(), bytes.size(), binary);
    if (json_depth(text, length) > kMaxJsonDepth)
        fail("JSON nested deeper than " + std::to_string(kMaxJsonDepth) + " levels");
    scene_.name = std::filesystem::path(path_).stem().string();
    prepare_compressed(bytes, binary);

    tg::TinyGLTF loader;
    loader.SetImageLoader(&keep_image, &image_bytes_);
    FolderFs folder;
    {
        std::error_code ec2;
        folder.root = std::filesystem::weakly_canonical(
            std::filesystem::absolute(path_, ec2).parent_path(), ec2);
    }
    loader.SetFsCallbacks(folder_callbacks(&folder));
    const std::string base_dir = std::filesystem::path(path_).parent_path().string();
    std::string err, warn;
    bool ok = false;
    try {
        ok = binary ? loader.LoadBinaryFromMemory(&model_, &err, &warn, bytes.data(),
                                                  static_cast<unsigned>(bytes.size()), base_dir)
                    : loader.LoadASCIIFromString(&model_, &err, &warn,
                                                 reinterpret_cast<const char*>(bytes.data()),
                                                 static_cast<unsigned>(bytes.size()), base_dir);
    } catch (const std::exception& e) {
        fail(std::string("malformed glTF file: ") + e.what());
    }
    if (!ok)
        fail(std::string("cannot load ") + (binary ? "binary glTF (.glb)" : "glTF") +
             " file: " + (err.empty() ? "unknown tinygltf error" : trim_trailing_space(err)));
    // tinygltf's own warnings, one line each.
    std::string line;
    for (std::istringstream lines(warn); std::getline(lines, line);)
        if (!trim_trailing_space(line).empty()) warn_once("tinygltf:" + line, "glTF: " + trim_trailing_space(line));
    decode_compressed();
}

// Compressed meshes: the JSON rewritten so that tinygltf parses it (gltf_compression.h).
void GltfLoader::prepare_compressed(std::vector<unsigned char>& bytes, bool binary) {
    try {
        compression_.prepare(bytes, binary);
    } catch (const Error& e) {
        fail(e.what());
    }
}

// ... and decoded into plain buffers once it has.
void GltfLoader::decode_compressed() {
    try {
        compression_.decode(model_);
    } catch (const Error& e) {
        fail(e.what());
    } catch (const std::bad_alloc&) {
        fail("out of memory decoding the compressed meshes");
    }
}

// Parses a .glb or .gltf held in memory; external files only from base_dir_.
void GltfLoader::parse_memory() {
    if (bytes_ == nullptr || size_ == 0) fail("empty buffer: no glTF data");
    if (size_ > 0xffffffffu) fail("buffer larger than 4 GiB");
    const bool binary = size_ >= 4 && std::memcmp(bytes_, "glTF", 4) == 0;
    scene_.name = path_;
    if (binary) {
        const std::string layout =
            glb_layout_error(static_cast<const unsigned char*>(bytes_), size_);
        if (!layout.empty()) fail("cannot load binary glTF (.glb) data: " + layout);
    }
    // Bound the JSON's nesting before the parser recurses through it.
    const auto [text, length] = json_text(static_cast<const unsigned char*>(bytes_), size_, binary);
    if (json_depth(text, length) > kMaxJsonDepth)
        fail("JSON nested deeper than " + std::to_string(kMaxJsonDepth) + " levels");
    // Compressed meshes: parse the rewritten copy.
    if (GltfCompression::needed(std::string_view(text, length))) {
        rewritten_.assign(bytes_, bytes_ + size_);
        prepare_compressed(rewritten_, binary);
        bytes_ = rewritten_.data(), size_ = rewritten_.size();
    }
    tg::TinyGLTF loader;
    loader.SetImageLoader(&keep_image, &image_bytes_);
    FolderFs folder;
    if (base_dir_.empty()) {
        // No folder given: a URI that is not a data URI is an error, not a file read.
        tg::FsCallbacks fs{};
        fs.FileExists = [](const std::string&, void*) { return true; };  // ReadWholeFile says no
        fs.ExpandFilePath = [](const std::string& p, void*) { return p; };
        fs.ReadWholeFile = [](std::vector<unsigned char>*, std::string* err, const std::string& p,
                              void*) {
            if (err)
                *err += "external file '" + p +
                        "' refused: loading from memory without a base folder\n";
            return false;
        };
        fs.WriteWholeFile = [](std::string* err, const std::string&,
                               const std::vector<unsigned char>&, void*) {
            if (err) *err += "writing is not allowed\n";
            return false;
        };
        loader.SetFsCallbacks(fs);
    } else {
        // External files from the base folder only.
        std::error_code ec;
        folder.root =
            std::filesystem::weakly_canonical(std::filesystem::absolute(base_dir_, ec), ec);
        loader.SetFsCallbacks(folder_callbacks(&folder));
    }
    std::string err, warn;
    bool ok = false;
    try {
        ok = binary ? loader.LoadBinaryFromMemory(&model_, &err, &warn, bytes_,
                                                  static_cast<unsigned>(size_), base_dir_)
                    : loader.LoadASCIIFromString(&model_, &err, &warn,
                                                 reinterpret_cast<const char*>(bytes_),
                                                 static_cast<unsigned>(size_), base_dir_);
    } catch (const std::exception& e) {
        fail(std::string("malformed glTF data: ") + e.what());
    }
    if (!ok)
        fail(std::string("cannot load ") + (binary ? "binary glTF (.glb)" : "glTF") +
             " data: " + (err.empty() ? "unknown tinygltf error" : trim_trailing_space(err)));
    std::string line;
    for (std::istringstream lines(warn); std::getline(lines, line);)
        if (!trim_trailing_space(line).empty()) warn_once("tinygltf:" + line, "glTF: " + trim_trailing_space(line));
    decode_compressed();
}

// Required extensions we lack are errors; everything else we skip is a warning, once.
void GltfLoader::check_features() {
    std::string missing;
    for (const std::string& name : model_.extensionsRequired)
        if (!supported_extension(name))
            missing += (missing.empty() ? "" : ", ") + name + unsupported_advice(name);
    if (!missing.empty()) fail("requires unsupported glTF extension(s): " + missing);
    scene_.extensions = model_.extensionsUsed;
    for (const std::string& name : model_.extensionsUsed)
        if (!supported_extension(name))
            warn_once("ext:" + name, "glTF extension " + name + " is not supported; ignored");
    if (!model_.skins.empty()) warn_once("skins", "skins are not supported; ignored");
    if (!model_.animations.empty())
        warn_once("animations", "animations are not supported; using the static pose");

    // Textures other than the four a material uses are not read.
    for (const tg::Material& m : model_.materials) {
        if (m.occlusionTexture.index >= 0)
            warn_once("occlusion", "occlusion textures are not used (paths trace occlusion)");
        if (m.alphaMode == "BLEND")
            warn_once("blend", "alphaMode BLEND is rendered opaque, e.g. '" + m.name + "'");
        if (m.normalTexture.index >= 0 && m.normalTexture.scale != 1.0)
            warn_once("normal scale", "normal texture scale is not supported; using 1");
    }
}

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
        warn_once("volume:" + what, what + ": " + kVolume +
                                        " without KHR_materials_transmission; ignored");
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

// The default scene's roots (scene 0 when none is marked; parentless nodes when no scene).
std::vector<int> GltfLoader::root_nodes() {
    if (!model_.scenes.empty()) {
        // No "scene" reads as -1 (then the first scene); another negative index is an error.
        if (model_.defaultScene < -1)
            fail("default scene " + std::to_string(model_.defaultScene) + " is negative");
        int s = model_.defaultScene < 0 ? 0 : model_.defaultScene;
        if (size_t(s) >= model_.scenes.size())
            fail("default scene " + std::to_string(s) + " out of range (file has " +
                 std::to_string(model_.scenes.size()) + " scenes)");
        return model_.scenes[size_t(s)].nodes;
    }
    std::vector<char> is_child(model_.nodes.size(), 0);
    for (const tg::Node& n : model_.nodes)
        for (int c : n.children)
            if (c >= 0 && size_t(c) < model_.nodes.size()) is_child[size_t(c)] = 1;
    std::vector<int> roots;
    for (size_t i = 0; i < model_.nodes.size(); ++i)
        if (!is_child[i]) roots.push_back(int(i));
    return roots;
}

// Depth-first, pre-order walk with an explicit stack; each node may appear once.
// Nodes may instance one mesh many times: a 2 MB file can hold 10^8 triangles. Count them
// (from the accessors' counts) before expanding any, and refuse a scene that would not fit.
void GltfLoader::check_triangle_budget(const std::vector<int>& roots) const {
    uint64_t triangles = 0, instances = 0;
    std::vector<char> seen(model_.nodes.size(), 0);
    std::vector<int> stack(roots.rbegin(), roots.rend());
    while (!stack.empty()) {
        const int index = stack.back();
        stack.pop_back();
        if (index < 0 || size_t(index) >= model_.nodes.size() || seen[size_t(index)]) continue;
        seen[size_t(index)] = 1;  // traverse() reports bad and repeated nodes
        const tg::Node& node = model_.nodes[size_t(index)];
        if (node.mesh >= 0 && size_t(node.mesh) < model_.meshes.size()) {
            ++instances;
            for (const tg::Primitive& prim : model_.meshes[size_t(node.mesh)].primitives) {
                if (prim.mode != TINYGLTF_MODE_TRIANGLES && prim.mode != -1) continue;
                const auto pos = prim.attributes.find("POSITION");
                const int corners = prim.indices >= 0              ? prim.indices
                                    : pos != prim.attributes.end() ? pos->second
                                                                   : -1;
                if (corners >= 0 && size_t(corners) < model_.accessors.size())
                    triangles += model_.accessors[size_t(corners)].count / 3;
            }
        }
        stack.insert(stack.end(), node.children.rbegin(), node.children.rend());
    }
    // Host memory per triangle while loading, validating, packing and building the tree (the
    // file, scene and device copies, SAH references and events): 485 B on the 871k dragon
    // (peak RSS 508 MB against 86 MB for the Cornell box).
    constexpr uint64_t kHostBytesPerTriangle = 512;
    constexpr uint64_t kMaxTriangles = uint64_t(1) << 28;  // 10 GiB on a device: beyond any
    const uint64_t available = host_memory_available();
    const uint64_t need = triangles * kHostBytesPerTriangle;
    if (triangles > kMaxTriangles || need > available / 2)
        fail("scene too large: " + std::to_string(triangles) + " triangles in " +
             std::to_string(instances) + " mesh instances need about " + human_bytes(need) +
             " of host memory to load and build (" + std::to_string(kHostBytesPerTriangle) +
             " B each); " + human_bytes(available) + " available, at most half is used" +
             (triangles > kMaxTriangles
                  ? "; and more than " + std::to_string(kMaxTriangles) + " triangles"
                  : ""));
}

void GltfLoader::traverse(const std::vector<int>& roots) {
    std::vector<char> seen(model_.nodes.size(), 0);
    std::vector<std::pair<int, glm::dmat4>> stack;
    for (auto it = roots.rbegin(); it != roots.rend(); ++it) stack.emplace_back(*it, glm::dmat4(1));
    while (!stack.empty()) {
        const auto [index, parent] = stack.back();
        stack.pop_back();
        // A valid node, not met before (the hierarchy must be a forest).
        if (index < 0 || size_t(index) >= model_.nodes.size())
            fail("node index " + std::to_string(index) + " out of range (file has " +
                 std::to_string(model_.nodes.size()) + " nodes)");
        if (seen[size_t(index)])
            fail("node " + std::to_string(index) +
                 " appears more than once in the node hierarchy (cycle or shared node)");
        seen[size_t(index)] = 1;
        const tg::Node& node = model_.nodes[size_t(index)];
        const glm::dmat4 world = parent * local_transform(node, index);
        // Its camera, its mesh, then its children in order.
        if (node.camera >= 0 || node.camera < -1) take_camera(node.camera, world);
        if (node.mesh >= 0 || node.mesh < -1) add_mesh(node.mesh, world);
        const auto lamp = node.extensions.find(kLightsPunctual);
        if (lamp != node.extensions.end()) {
            const tg::Value& light = lamp->second.Get("light");
            if (!light.IsNumber())
                fail("node " + std::to_string(index) + ": " + kLightsPunctual +
                     " without a light index");
            add_light(light.GetNumberAsInt(), world, index);
        }
        for (auto c = node.children.rbegin(); c != node.children.rend(); ++c)
            stack.emplace_back(*c, world);
    }
}

// The node's matrix, or translation * rotation * scale.
glm::dmat4 GltfLoader::local_transform(const tg::Node& node, int index) {
    const std::string what = "node " + std::to_string(index) + ": ";
    if (!node.matrix.empty()) {
        if (node.matrix.size() != 16) fail(what + "matrix must have 16 numbers");
        return glm::make_mat4(node.matrix.data());  // column-major, as in glTF
    }
    glm::dmat4 m(1);
    if (!node.translation.empty()) {
        if (node.translation.size() != 3) fail(what + "translation must have 3 numbers");
        m = glm::translate(m, glm::make_vec3(node.translation.data()));
    }
    if (!node.rotation.empty()) {
        if (node.rotation.size() != 4) fail(what + "rotation must have 4 numbers");
        const auto& r = node.rotation;  // x, y, z, w
        glm::dquat q(r[3], r[0], r[1], r[2]);
        const double len = glm::length(q);
        if (len > 0.0) q = q / len;
        m = m * glm::mat4_cast(q);
    }
    if (!node.scale.empty()) {
        if (node.scale.size() != 3) fail(what + "scale must have 3 numbers");
        m = glm::scale(m, glm::make_vec3(node.scale.data()));
    }
    return m;
}

// A lamp of KHR_lights_punctual at the node's world transform: position, direction -Z.
void GltfLoader::add_light(int light, const glm::dmat4& world, int node) {
    if (light < 0 || size_t(light) >= model_.lights.size())
        fail("node " + std::to_string(node) + ": light index " + std::to_string(light) +
             " out of range (file has " + std::to_string(model_.lights.size()) + " lights)");
    const tg::Light& l = model_.lights[size_t(light)];
    const std::string label =
        "light " + (l.name.empty() ? std::to_string(light) : "'" + l.name + "'");
    PunctualLight p;
    p.name = l.name;
    if (l.type == "point")
        p.kind = PunctualKind::Point;
    else if (l.type == "spot")
        p.kind = PunctualKind::Spot;
    else if (l.type == "directional")
        p.kind = PunctualKind::Directional;
    else
        fail(label + ": unknown type '" + l.type + "' (point, spot or directional)");
    glm::dvec3 color(1.0);
    if (!l.color.empty()) {
        if (l.color.size() != 3) fail(label + ": color must have 3 numbers");
        color = glm::make_vec3(l.color.data());
    }
    const auto finite_nonnegative = [](double v) { return std::isfinite(v) && v >= 0; };
    if (!finite_nonnegative(color.x) || !finite_nonnegative(color.y) ||
        !finite_nonnegative(color.z) || !finite_nonnegative(l.intensity))
        fail(label + ": color and intensity must be finite and >= 0");
    // In double, then checked: a finite intensity can exceed single precision.
    const glm::dvec3 watts = color * (l.intensity / kLumensPerWatt);
    if (!(std::max({watts.x, watts.y, watts.z}) <= double(FLT_MAX)))
        fail(label + ": color x intensity (" +
             std::to_string(std::max({watts.x, watts.y, watts.z})) +
             " W/sr) overflows single precision (3.4e38)");
    p.intensity = glm::vec3(watts);
    if (!finite_nonnegative(l.range)) fail(label + ": range must be finite and > 0");
    p.range = p.kind == PunctualKind::Directional ? 0.f : float(l.range);
    if (p.kind == PunctualKind::Spot) {
        const double inner = l.spot.innerConeAngle, outer = l.spot.outerConeAngle;
        if (!(inner >= 0 && inner <= outer && outer <= M_PI / 2 + 1e-9))
            fail(label + ": spot cone angles must satisfy 0 <= inner <= outer <= pi/2 (inner " +
                 std::to_string(inner) + ", outer " + std::to_string(outer) + ")");
        p.inner_cone = float(inner), p.outer_cone = float(outer);
    }
    p.position = glm::vec3(world * glm::dvec4(0, 0, 0, 1));
    const glm::dvec3 dir = glm::dmat3(world) * glm::dvec3(0, 0, -1);
    const double len = glm::length(dir);
    if (p.kind != PunctualKind::Point && !(len > 1e-12 && std::isfinite(len)))
        fail(label + ": degenerate node transform (no direction)");
    if (p.kind != PunctualKind::Point) p.direction = glm::vec3(dir / len);
    if (!std::isfinite(p.position.x + p.position.y + p.position.z))
        fail(label + ": non-finite position");
    scene_.punctual_lights.push_back(p);
}

// The first perspective camera: position, forward = -Z and up = +Y of the node, in world space.
void GltfLoader::take_camera(int camera, const glm::dmat4& world) {
    if (camera < 0 || size_t(camera) >= model_.cameras.size())
        fail("camera index " + std::to_string(camera) + " out of range (file has " +
             std::to_string(model_.cameras.size()) + " cameras)");
    const tg::Camera& c = model_.cameras[size_t(camera)];
    const std::string label = c.name.empty() ? std::to_string(camera) : "'" + c.name + "'";
    if (c.type != "perspective") {
        warn_once("camera:" + c.type, "non-perspective (" + c.type +
                                          ") cameras are not supported; camera " + label +
                                          " ignored");
        return;
    }
    if (scene_.has_camera) return;
    const double yfov = c.perspective.yfov;
    if (!(yfov > 0.0 && yfov < glm::pi<double>()))
        fail("camera " + label + ": yfov must be in (0, pi) radians");
    const glm::dmat3 basis(world);
    glm::dvec3 forward = basis * glm::dvec3(0, 0, -1), up = basis * glm::dvec3(0, 1, 0);
    // Orthonormalize (the node may carry scale or shear).
    const double fl = glm::length(forward);
    if (!(fl > 1e-12)) fail("camera " + label + ": degenerate node transform");
    forward /= fl;
    up -= glm::dot(up, forward) * forward;
    const double ul = glm::length(up);
    if (!(ul > 1e-12)) fail("camera " + label + ": degenerate node transform");
    scene_.camera.position = glm::vec3(world * glm::dvec4(0, 0, 0, 1));
    scene_.camera.forward = glm::vec3(forward);
    scene_.camera.up = glm::vec3(up / ul);
    scene_.camera.yfov = float(yfov);
    scene_.has_camera = true;
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

// Every TRIANGLES primitive of the mesh, transformed to world space.
void GltfLoader::add_mesh(int mesh, const glm::dmat4& world) {
    if (mesh < 0 || size_t(mesh) >= model_.meshes.size())
        fail("mesh index " + std::to_string(mesh) + " out of range (file has " +
             std::to_string(model_.meshes.size()) + " meshes)");
    const tg::Mesh& m = model_.meshes[size_t(mesh)];
    // A mirroring transform flips the winding, so swap two vertices to keep the front side.
    const bool flip = glm::determinant(glm::dmat3(world)) < 0.0;
    for (size_t p = 0; p < m.primitives.size(); ++p) {
        const tg::Primitive& prim = m.primitives[p];
        const std::string where = "mesh " + std::to_string(mesh) +
                                  (m.name.empty() ? "" : " '" + m.name + "'") + " primitive " +
                                  std::to_string(p);
        if (!prim.targets.empty())
            warn_once("morph", "morph targets are not supported; using the base mesh");
        if (prim.mode != TINYGLTF_MODE_TRIANGLES && prim.mode != -1) {
            warn_once("mode:" + std::to_string(prim.mode),
                      "primitive mode " + mode_name(prim.mode) + " is not supported; skipped");
            continue;
        }
        const auto pos = prim.attributes.find("POSITION");
        if (pos == prim.attributes.end()) {
            warn_once("no POSITION", where + " has no POSITION attribute; skipped");
            continue;
        }
        const uint32_t material = material_index(prim.material, where);
        const std::vector<glm::vec3> v = read_positions(pos->second, where);
        // Per-vertex normals and texture coordinates 0, when the primitive has them.
        const auto nrm = prim.attributes.find("NORMAL");
        const auto tc = prim.attributes.find("TEXCOORD_0");
        std::vector<glm::vec3> normals;
        std::vector<glm::vec2> uvs;
        if (nrm != prim.attributes.end()) normals = read_normals(nrm->second, where);
        if (tc != prim.attributes.end()) uvs = read_texcoords(tc->second, where);
        if ((!normals.empty() && normals.size() != v.size()) ||
            (!uvs.empty() && uvs.size() != v.size()))
            fail(where + ": NORMAL or TEXCOORD_0 count differs from POSITION's");
        const bool attributes = !normals.empty() || !uvs.empty() || !scene_.attributes.empty();
        if (!normals.empty()) scene_.vertex_normals = true;
        if (attributes) scene_.attributes.resize(scene_.triangles.size());
        // Normals transform by the inverse transpose.
        const glm::dmat3 normal_matrix = glm::transpose(glm::inverse(glm::dmat3(world)));
        // Corner list: the indices, or 0, 1, 2, ... when not indexed.
        std::vector<uint32_t> idx;
        if (prim.indices >= 0 || prim.indices < -1) {
            idx = read_indices(prim.indices, where);
        } else {
            idx.resize(v.size());
            for (size_t i = 0; i < idx.size(); ++i) idx[i] = uint32_t(i);
        }
        if (idx.size() % 3 != 0)
            warn_once("count%3", where + ": corner count " + std::to_string(idx.size()) +
                                     " is not a multiple of 3; extra corners ignored");
        for (size_t i = 0; i + 2 < idx.size(); i += 3) {
            glm::vec3 c[3];
            VertexAttributes va;
            for (int k = 0; k < 3; ++k) {
                const uint32_t j = idx[i + size_t(k)];
                if (j >= v.size())
                    fail(where + ": index " + std::to_string(j) + " out of range (POSITION has " +
                         std::to_string(v.size()) + " vertices)");
                c[k] = glm::vec3(world * glm::dvec4(glm::dvec3(v[j]), 1.0));
                if (!normals.empty()) {
                    const glm::dvec3 n = normal_matrix * glm::dvec3(normals[j]);
                    const double len = glm::length(n);
                    va.n[k] = len > 0.0 && std::isfinite(len) ? glm::vec3(n / len) : glm::vec3(0.f);
                }
                if (!uvs.empty()) {
                    // The material's KHR_texture_transform, baked in.
                    const glm::dvec3 t = material < uv_transforms_.size()
                                             ? uv_transforms_[material] * glm::dvec3(uvs[j], 1.0)
                                             : glm::dvec3(uvs[j], 1.0);
                    va.uv[k] = glm::vec2(t);
                }
            }
            if (flip) {
                std::swap(c[1], c[2]);
                std::swap(va.n[1], va.n[2]);
                std::swap(va.uv[1], va.uv[2]);
            }
            scene_.triangles.push_back({c[0], c[1], c[2], material});
            if (attributes) scene_.attributes.push_back(va);
        }
    }
}

// Start of `count` elements of `elem` bytes, `stride` apart, `offset` bytes into buffer view
// `view`, after checking that the view lies in its buffer and the elements in the view.
const unsigned char* GltfLoader::view_data(int view, size_t offset, size_t count, size_t stride,
                                           size_t elem, const std::string& what) const {
    if (view < 0 || size_t(view) >= model_.bufferViews.size())
        fail(what + ": bufferView " + std::to_string(view) + " out of range (file has " +
             std::to_string(model_.bufferViews.size()) + " buffer views)");
    const tg::BufferView& bv = model_.bufferViews[size_t(view)];
    if (bv.buffer < 0 || size_t(bv.buffer) >= model_.buffers.size())
        fail(what + ": buffer " + std::to_string(bv.buffer) + " out of range");
    const std::vector<unsigned char>& data = model_.buffers[size_t(bv.buffer)].data;
    if (bv.byteOffset > data.size() || bv.byteLength > data.size() - bv.byteOffset)
        fail(what + ": bufferView " + std::to_string(view) + " lies outside its buffer (" +
             std::to_string(data.size()) + " bytes)");
    // offset + (count - 1) * stride + elem <= byteLength, without overflow.
    const size_t length = bv.byteLength;
    const bool fits = count == 0 || (offset <= length && elem <= length - offset &&
                                     (count - 1) <= (length - offset - elem) / stride);
    if (!fits)
        fail(what + ": accessor out of bounds (" + std::to_string(count) + " elements of " +
             std::to_string(elem) + " bytes, stride " + std::to_string(stride) + ", offset " +
             std::to_string(offset) + " in bufferView " + std::to_string(view) + " of " +
             std::to_string(length) + " bytes)");
    return data.data() + bv.byteOffset + offset;
}

// An accessor's elements, decoded from its buffer view (zeros without one), then the sparse
// substitutions applied.
template <class T, class Decode>
std::vector<T> GltfLoader::read_accessor(const tg::Accessor& a, size_t elem,
                                         const std::string& what, Decode decode) const {
    // Base values.
    const unsigned char* base = nullptr;
    size_t stride = elem;
    if (a.bufferView >= 0 || a.bufferView < -1) {
        const int view = a.bufferView;
        if (view >= 0 && size_t(view) < model_.bufferViews.size()) {
            const size_t s = model_.bufferViews[size_t(view)].byteStride;
            if (s != 0 && s < elem)
                fail(what + ": byteStride " + std::to_string(s) + " smaller than an element");
            if (s != 0) stride = s;
        }
        base = view_data(view, a.byteOffset, a.count, stride, elem, what);
    } else if (a.count > kMaxZeroAccessorCount) {
        // No data behind it: all zeros but the sparse values. Bounded before allocating (a
        // count near 2^28 took gigabytes before anything else could refuse the file).
        fail(what + ": accessor count " + std::to_string(a.count) +
             " without a bufferView (at most " + std::to_string(kMaxZeroAccessorCount) + ")");
    }
    // Sparse substitutions (tightly packed indices and values): their views are checked
    // against the file's data before the elements are allocated.
    const unsigned char* ip = nullptr;
    const unsigned char* vp = nullptr;
    size_t isize = 0, n = 0;
    if (a.sparse.isSparse) {
        isize = index_size(a.sparse.indices.componentType);
        if (isize == 0) fail(what + ": sparse indices must be unsigned byte, short or int");
        if (a.sparse.count < 0 || a.sparse.indices.byteOffset < 0 || a.sparse.values.byteOffset < 0)
            fail(what + ": negative sparse count or byteOffset");
        n = size_t(a.sparse.count);
        if (n > a.count)
            fail(what + ": " + std::to_string(n) + " sparse values for " + std::to_string(a.count) +
                 " elements");
        ip = view_data(a.sparse.indices.bufferView, size_t(a.sparse.indices.byteOffset), n, isize,
                       isize, what + " (sparse indices)");
        vp = view_data(a.sparse.values.bufferView, size_t(a.sparse.values.byteOffset), n, elem,
                       elem, what + " (sparse values)");
    }
    std::vector<T> out(a.count, T{});
    if (base)
        for (size_t i = 0; i < a.count; ++i) out[i] = decode(base + i * stride);
    if (a.sparse.isSparse) {
        for (size_t i = 0; i < n; ++i) {
            const uint32_t j = read_index(ip + i * isize, isize);
            if (j >= out.size())
                fail(what + ": sparse index " + std::to_string(j) + " out of range");
            out[j] = decode(vp + i * elem);
        }
    }
    return out;
}

// Accessor `accessor`, after checking that the file has it.
const tg::Accessor& GltfLoader::accessor_at(int accessor, const std::string& what) const {
    if (accessor < 0 || size_t(accessor) >= model_.accessors.size())
        fail(what + " out of range (file has " + std::to_string(model_.accessors.size()) +
             " accessors)");
    return model_.accessors[size_t(accessor)];
}

// The elements of an accessor of N components of any type the attribute allows, as floats:
// normalized integers mapped as glTF says, other integers as they are (KHR_mesh_quantization).
template <int N>
std::vector<glm::vec<N, float>> GltfLoader::read_vectors(const tg::Accessor& a,
                                                         const std::string& what) const {
    const size_t size = component_size(a.componentType);
    const int type = a.componentType;
    const bool normalized = a.normalized;
    return read_accessor<glm::vec<N, float>>(a, N * size, what, [=](const unsigned char* p) {
        glm::vec<N, float> v;
        for (int k = 0; k < N; ++k) v[k] = component_value(p + size_t(k) * size, type, normalized);
        return v;
    });
}

// POSITION: float, or (KHR_mesh_quantization) 8- or 16-bit integers, normalized or not.
std::vector<glm::vec3> GltfLoader::read_positions(int accessor, const std::string& where) const {
    const std::string what = where + " POSITION accessor " + std::to_string(accessor);
    const tg::Accessor& a = accessor_at(accessor, what);
    if (a.type != TINYGLTF_TYPE_VEC3 || component_size(a.componentType) == 0 ||
        a.componentType == TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT)
        fail(what +
             ": POSITION must be VEC3 of float or (KHR_mesh_quantization) byte, "
             "unsigned byte, short or unsigned short");
    std::vector<glm::vec3> out = read_vectors<3>(a, what);
    // Non-finite positions named as the file has them (before any node transform).
    for (size_t i = 0; i < out.size(); ++i) {
        const glm::vec3& v = out[i];
        if (!std::isfinite(v.x) || !std::isfinite(v.y) || !std::isfinite(v.z)) {
            std::ostringstream o;
            o << what << ": non-finite position at element " << i << " = (" << v.x << ", " << v.y
              << ", " << v.z << ")";
            fail(o.str());
        }
    }
    return out;
}

// NORMAL: float, or (KHR_mesh_quantization) normalized byte or short.
std::vector<glm::vec3> GltfLoader::read_normals(int accessor, const std::string& where) const {
    const std::string what = where + " NORMAL accessor " + std::to_string(accessor);
    const tg::Accessor& a = accessor_at(accessor, what);
    const bool quantized = a.normalized && (a.componentType == TINYGLTF_COMPONENT_TYPE_BYTE ||
                                            a.componentType == TINYGLTF_COMPONENT_TYPE_SHORT);
    if (a.type != TINYGLTF_TYPE_VEC3 ||
        (a.componentType != TINYGLTF_COMPONENT_TYPE_FLOAT && !quantized))
        fail(what +
             ": NORMAL must be VEC3 of float or (KHR_mesh_quantization) normalized "
             "byte or short");
    std::vector<glm::vec3> out = read_vectors<3>(a, what);
    for (glm::vec3& n : out)
        if (!std::isfinite(n.x) || !std::isfinite(n.y) || !std::isfinite(n.z)) n = glm::vec3(0.f);
    return out;
}

// TEXCOORD_0: float, normalized unsigned byte or short, or (KHR_mesh_quantization) any 8- or
// 16-bit integer, normalized or not.
std::vector<glm::vec2> GltfLoader::read_texcoords(int accessor, const std::string& where) const {
    const std::string what = where + " TEXCOORD_0 accessor " + std::to_string(accessor);
    const tg::Accessor& a = accessor_at(accessor, what);
    if (a.type != TINYGLTF_TYPE_VEC2) fail(what + ": TEXCOORD_0 must be VEC2");
    if (component_size(a.componentType) == 0 ||
        a.componentType == TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT)
        fail(what + ": TEXCOORD_0 must be float or 8- or 16-bit integers");
    std::vector<glm::vec2> out = read_vectors<2>(a, what);
    for (glm::vec2& t : out)
        if (!std::isfinite(t.x) || !std::isfinite(t.y) || std::fabs(t.x) > 1e6f ||
            std::fabs(t.y) > 1e6f)
            fail(what + ": texture coordinate not finite or beyond 1e6");
    return out;
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

std::vector<uint32_t> GltfLoader::read_indices(int accessor, const std::string& where) const {
    const std::string what = where + " index accessor " + std::to_string(accessor);
    const tg::Accessor& a = accessor_at(accessor, what);
    const size_t size = index_size(a.componentType);
    if (size == 0 || a.type != TINYGLTF_TYPE_SCALAR)
        fail(what + ": indices must be SCALAR unsigned byte, short or int");
    return read_accessor<uint32_t>(a, size, what,
                                   [size](const unsigned char* p) { return read_index(p, size); });
}

}  // namespace

Scene load_gltf(const std::string& path) {
    return GltfLoader(path).load();
}

Scene load_gltf_memory(const void* data, size_t size, const std::string& name,
                       const std::string& base_dir) {
    return GltfLoader(name, static_cast<const unsigned char*>(data), size, base_dir).load();
}

}  // namespace mcpt
