// The glTF loader's file handling (gltf_loader_internal.h): the .glb container and the JSON
// checked before tinygltf parses them, external files only from the scene's own folder, the
// compressed meshes' rewrite and decode, and the extensions a file requires or uses.
#include <algorithm>
#include <cctype>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <sstream>

#include "common/io/texture_image.h"
#include "common/scene/gltf_loader_internal.h"

namespace mcpt {
namespace gltf {
namespace {

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

// The JSON parser recurses once per nesting level: a file nesting arrays tens of thousands
// deep would overflow the stack. glTF itself nests a handful of levels; extras may add some.
constexpr int kMaxJsonDepth = 256;

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

std::string trim_trailing_space(std::string s) {
    while (!s.empty() && std::isspace(static_cast<unsigned char>(s.back()))) s.pop_back();
    return s;
}

}  // namespace

// Extensions the loader reads (the decoders only where this build has their libraries).
bool supported_extension(const std::string& name) {
    return name == kEmissiveStrength || name == kTransmission || name == kIor ||
           name == kSpecular || name == kVolume || name == kClearcoat || name == kSheen ||
           name == kLightsPunctual || name == kQuantization || name == kTextureTransform ||
           (name == kTextureWebp && has_webp_decoder()) ||
           (name == kMeshoptCompression && GltfCompression::has_meshopt()) ||
           (name == kDracoCompression && GltfCompression::has_draco());
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
    parse(loader, bytes.data(), bytes.size(), binary, base_dir, "file");
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
    parse(loader, bytes_, size_, binary, base_dir_, "data");
}

// tinygltf's parse of `size` bytes at `data` (a .glb or .gltf, named a `noun` in messages),
// its warnings kept, then the compressed meshes decoded.
void GltfLoader::parse(tg::TinyGLTF& loader, const unsigned char* data, size_t size, bool binary,
                       const std::string& base_dir, const char* noun) {
    std::string err, warn;
    bool ok = false;
    try {
        ok = binary ? loader.LoadBinaryFromMemory(&model_, &err, &warn, data,
                                                  static_cast<unsigned>(size), base_dir)
                    : loader.LoadASCIIFromString(&model_, &err, &warn,
                                                 reinterpret_cast<const char*>(data),
                                                 static_cast<unsigned>(size), base_dir);
    } catch (const std::exception& e) {
        fail(std::string("malformed glTF ") + noun + ": " + e.what());
    }
    if (!ok)
        fail(std::string("cannot load ") + (binary ? "binary glTF (.glb)" : "glTF") + " " + noun +
             ": " + (err.empty() ? "unknown tinygltf error" : trim_trailing_space(err)));
    // tinygltf's own warnings, one line each.
    std::string line;
    for (std::istringstream lines(warn); std::getline(lines, line);)
        if (!trim_trailing_space(line).empty())
            warn_once("tinygltf:" + line, "glTF: " + trim_trailing_space(line));
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

}  // namespace gltf
}  // namespace mcpt
