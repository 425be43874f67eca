// The glTF loader's class, shared by its four parts: gltf_loader.cpp (the node hierarchy,
// meshes, lamps and the camera; its opening comment maps glTF onto the scene),
// gltf_file.cpp (the file: containers, external files, extensions), gltf_materials.cpp
// (materials and textures) and gltf_accessors.cpp (buffer data). Not a public header.
#pragma once

#include <cstdint>
#include <glm/glm.hpp>
#include <map>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "common/error.h"
#include "common/scene/gltf_compression.h"
#include "common/scene/scene.h"
#include "common/scene/tinygltf.h"

namespace mcpt {
namespace gltf {

namespace tg = tinygltf;

constexpr const char* kEmissiveStrength = "KHR_materials_emissive_strength";
constexpr const char* kTransmission = "KHR_materials_transmission";
constexpr const char* kIor = "KHR_materials_ior";
constexpr const char* kSpecular = "KHR_materials_specular";
constexpr const char* kVolume = "KHR_materials_volume";
constexpr const char* kClearcoat = "KHR_materials_clearcoat";
constexpr const char* kSheen = "KHR_materials_sheen";

constexpr const char* kLightsPunctual = "KHR_lights_punctual";
constexpr const char* kQuantization = "KHR_mesh_quantization";
constexpr const char* kTextureTransform = "KHR_texture_transform";
constexpr const char* kTextureWebp = "EXT_texture_webp";
constexpr const char* kTextureBasisu = "KHR_texture_basisu";

// Extensions the loader reads (the decoders only where this build has their libraries).
bool supported_extension(const std::string& name);

// Encoded image bytes by image index, kept by tinygltf's image callback (gltf_file.cpp).
using ImageBytes = std::map<int, std::vector<unsigned char>>;

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
    void parse(tg::TinyGLTF& loader, const unsigned char* data, size_t size, bool binary,
               const std::string& base_dir, const char* noun);
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

}  // namespace gltf
}  // namespace mcpt
