// glTF's mesh compression extensions, EXT_meshopt_compression (meshoptimizer) and
// KHR_draco_mesh_compression (Draco), decoded into plain buffers, buffer views and accessors,
// so that the loader reads and checks a compressed file exactly as an uncompressed one.
//
// tinygltf 2.7 cannot parse either as written: a meshopt fallback buffer has a byteLength but
// no data, and a Draco primitive's index accessor has no buffer view. prepare() rewrites the
// JSON before tinygltf sees it (the fallback buffer becomes a one-byte data URI, the Draco
// primitive's indices are set aside) and decode() puts the decoded data in place afterwards.
// It also hands WebP images in data URIs over as octet streams (tinygltf takes a few image
// media types only).
#ifndef MCPT_SCENE_GLTF_COMPRESSION_H
#define MCPT_SCENE_GLTF_COMPRESSION_H

#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

namespace tinygltf {
class Model;
}

namespace mcpt {

// The extensions this file decodes.
inline constexpr const char* kMeshoptCompression = "EXT_meshopt_compression";
inline constexpr const char* kDracoCompression = "KHR_draco_mesh_compression";

class GltfCompression {
  public:
    // Rewrites `bytes` (a .gltf's JSON text, or a whole .glb, its JSON chunk rebuilt) when the
    // file uses either extension; returns false, leaving `bytes` as they were, when it uses
    // neither. Throws Error for a malformed extension object.
    bool prepare(std::vector<unsigned char>& bytes, bool binary);
    // Whether JSON text names anything prepare() rewrites (a quick scan, before any parse).
    static bool needed(std::string_view json);
    // Decodes every compressed buffer view and primitive of the model tinygltf parsed from the
    // prepared bytes. Throws Error naming the buffer view or mesh and the extension.
    void decode(tinygltf::Model& model) const;
    // Whether this build has each decoder (Debian: libmeshoptimizer-dev, libdraco-dev).
    static bool has_meshopt();
    static bool has_draco();

  private:
    struct MeshoptView {
        int view = -1;    // the buffer view the decoded data fills
        int buffer = -1;  // the compressed stream: buffer, offset, length
        uint64_t offset = 0, length = 0;
        uint64_t stride = 0, count = 0;
        std::string mode, filter;
    };
    struct FallbackBuffer {
        int buffer = -1;
        uint64_t length = 0;  // its real byteLength (tinygltf was given one byte)
    };
    struct DracoPrimitive {
        int mesh = -1, primitive = -1;
        int view = -1;     // the Draco stream
        int indices = -1;  // the index accessor tinygltf was not shown
        std::vector<std::pair<std::string, int>> attributes;  // glTF attribute, Draco unique id
    };
    void decode_meshopt(tinygltf::Model& model) const;
    void decode_draco(tinygltf::Model& model) const;

    std::vector<MeshoptView> meshopt_views_;
    std::vector<FallbackBuffer> fallbacks_;
    std::vector<DracoPrimitive> draco_;
};

}  // namespace mcpt

#endif  // MCPT_SCENE_GLTF_COMPRESSION_H
