// EXT_meshopt_compression and KHR_draco_mesh_compression: the JSON set up for tinygltf, the
// streams decoded by the libraries made for them, every count and range checked first.
#include "common/scene/gltf_compression.h"

#include <cstring>
#include <limits>
#include <nlohmann/json.hpp>

#include "common/error.h"
#include "common/io/host_memory.h"
#include "common/scene/tinygltf.h"

#if defined(MCPT_WITH_MESHOPT)
#include <meshoptimizer.h>
#endif
#if defined(MCPT_WITH_DRACO)
#include <draco/compression/decode.h>
#include <draco/mesh/mesh.h>
#endif

namespace mcpt {
namespace {

using json = nlohmann::json;
namespace tg = tinygltf;

// tinygltf 2.7 takes data URIs of a few media types only; WebP images (EXT_texture_webp) are
// handed to it as octet streams.
const char* const kWebpUri = "data:image/webp;base64,";
const char* const kOctetUri = "data:application/octet-stream;base64,";

// Decoded data in all at most (fallback buffers, Draco's attributes and indices): 2 GiB, and
// at most half the host's available memory.
constexpr uint64_t kMaxDecodedBytes = uint64_t(2) << 30;
// Vertices or indices of one Draco primitive at most.
constexpr uint64_t kMaxDracoElements = uint64_t(1) << 28;

// A non-negative integer member of an extension object (`fallback` when absent).
uint64_t count_member(const json& o, const char* key, const std::string& what,
                      int64_t fallback = -1) {
    const auto it = o.find(key);
    if (it == o.end()) {
        if (fallback < 0) throw Error(what + ": '" + key + "' is missing");
        return uint64_t(fallback);
    }
    if (!it->is_number_unsigned() && !(it->is_number_integer() && it->get<int64_t>() >= 0))
        throw Error(what + ": '" + key + "' must be a non-negative integer");
    return it->get<uint64_t>();
}

std::string string_member(const json& o, const char* key, const std::string& what,
                          const char* fallback) {
    const auto it = o.find(key);
    if (it == o.end() && fallback) return fallback;
    if (it == o.end() || !it->is_string()) throw Error(what + ": '" + key + "' must be a string");
    return it->get<std::string>();
}

// The extension object `name` of a JSON object, or null.
const json* extension(const json& o, const char* name) {
    if (!o.is_object()) return nullptr;
    const auto e = o.find("extensions");
    if (e == o.end() || !e->is_object()) return nullptr;
    const auto x = e->find(name);
    return x != e->end() && x->is_object() ? &*x : nullptr;
}

int index_of(uint64_t v, const std::string& what) {
    if (v > uint64_t(std::numeric_limits<int>::max())) throw Error(what + " out of range");
    return int(v);
}

#if defined(MCPT_WITH_MESHOPT) || defined(MCPT_WITH_DRACO)
// The buffer view's bytes [offset, offset + length) after checking that they lie in its buffer.
unsigned char* view_bytes(tg::Model& model, int view, uint64_t& length, const std::string& what) {
    if (view < 0 || size_t(view) >= model.bufferViews.size())
        throw Error(what + ": bufferView " + std::to_string(view) + " out of range (file has " +
                    std::to_string(model.bufferViews.size()) + ")");
    const tg::BufferView& bv = model.bufferViews[size_t(view)];
    if (bv.buffer < 0 || size_t(bv.buffer) >= model.buffers.size())
        throw Error(what + ": buffer " + std::to_string(bv.buffer) + " out of range");
    std::vector<unsigned char>& data = model.buffers[size_t(bv.buffer)].data;
    if (bv.byteOffset > data.size() || bv.byteLength > data.size() - bv.byteOffset)
        throw Error(what + ": bufferView " + std::to_string(view) + " lies outside its buffer");
    length = bv.byteLength;
    return data.data() + bv.byteOffset;
}
#endif

}  // namespace

bool GltfCompression::has_meshopt() {
#if defined(MCPT_WITH_MESHOPT)
    return true;
#else
    return false;
#endif
}

bool GltfCompression::has_draco() {
#if defined(MCPT_WITH_DRACO)
    return true;
#else
    return false;
#endif
}

bool GltfCompression::needed(std::string_view json) {
    return json.find(kMeshoptCompression) != std::string_view::npos ||
           json.find(kDracoCompression) != std::string_view::npos ||
           json.find(kWebpUri) != std::string_view::npos;
}

bool GltfCompression::prepare(std::vector<unsigned char>& bytes, bool binary) {
    // The JSON text: all of a .gltf, the first chunk of a .glb (its layout already checked).
    size_t begin = 0, length = bytes.size();
    if (binary) {
        uint32_t json_length = 0;
        std::memcpy(&json_length, bytes.data() + 12, 4);
        begin = 20, length = json_length;
    }
    const char* text = reinterpret_cast<const char*>(bytes.data()) + begin;
    if (!needed(std::string_view(text, length))) return false;
    json doc = json::parse(text, text + length, nullptr, /*allow_exceptions=*/false);
    if (!doc.is_object()) return false;  // tinygltf says what is wrong with it
    bool changed = false;
    // Meshopt: each compressed view's stream, and fallback buffers given one byte of data.
    if (auto views = doc.find("bufferViews"); views != doc.end() && views->is_array()) {
        for (size_t i = 0; i < views->size(); ++i) {
            const json* e = extension((*views)[i], kMeshoptCompression);
            if (!e) continue;
            const std::string what =
                "bufferView " + std::to_string(i) + " (" + kMeshoptCompression + ")";
            MeshoptView m;
            m.view = int(i);
            m.buffer = index_of(count_member(*e, "buffer", what), what + ": buffer");
            m.offset = count_member(*e, "byteOffset", what, 0);
            m.length = count_member(*e, "byteLength", what);
            m.stride = count_member(*e, "byteStride", what);
            m.count = count_member(*e, "count", what);
            m.mode = string_member(*e, "mode", what, nullptr);
            m.filter = string_member(*e, "filter", what, "NONE");
            meshopt_views_.push_back(m);
        }
    }
    if (auto buffers = doc.find("buffers"); buffers != doc.end() && buffers->is_array()) {
        for (size_t i = 0; i < buffers->size(); ++i) {
            json& b = (*buffers)[i];
            const json* e = extension(b, kMeshoptCompression);
            if (!e || !e->value("fallback", false) || b.contains("uri")) continue;
            const std::string what =
                "buffer " + std::to_string(i) + " (" + kMeshoptCompression + ")";
            fallbacks_.push_back({int(i), count_member(b, "byteLength", what)});
            b["byteLength"] = 1;
            b["uri"] = "data:application/octet-stream;base64,AA==";
            changed = true;
        }
    }
    // WebP images in data URIs.
    if (auto images = doc.find("images"); images != doc.end() && images->is_array()) {
        for (json& image : *images) {
            if (!image.is_object() || !image.contains("uri") || !image["uri"].is_string()) continue;
            const std::string uri = image["uri"].get<std::string>();
            if (uri.rfind(kWebpUri, 0) != 0) continue;
            image["uri"] = kOctetUri + uri.substr(std::strlen(kWebpUri));
            changed = true;
        }
    }
    // Draco: each compressed primitive, its index accessor set aside (it has no buffer view).
    if (auto meshes = doc.find("meshes"); meshes != doc.end() && meshes->is_array()) {
        for (size_t m = 0; m < meshes->size(); ++m) {
            json& mesh = (*meshes)[m];
            if (!mesh.is_object() || !mesh.contains("primitives") || !mesh["primitives"].is_array())
                continue;
            json& prims = mesh["primitives"];
            for (size_t p = 0; p < prims.size(); ++p) {
                const json* e = extension(prims[p], kDracoCompression);
                if (!e) continue;
                const std::string what = "mesh " + std::to_string(m) + " primitive " +
                                         std::to_string(p) + " (" + kDracoCompression + ")";
                DracoPrimitive d;
                d.mesh = int(m), d.primitive = int(p);
                d.view = index_of(count_member(*e, "bufferView", what), what + ": bufferView");
                const auto attrs = e->find("attributes");
                if (attrs == e->end() || !attrs->is_object())
                    throw Error(what + ": 'attributes' must be an object");
                for (const auto& [name, id] : attrs->items()) {
                    if (!id.is_number_integer() || id.get<int64_t>() < 0 ||
                        id.get<int64_t>() > std::numeric_limits<int>::max())
                        throw Error(what + ": attribute " + name + " needs a Draco id >= 0");
                    d.attributes.emplace_back(name, id.get<int>());
                }
                if (prims[p].contains("indices")) {
                    const json& ix = prims[p]["indices"];
                    if (!ix.is_number_integer() || ix.get<int64_t>() < 0)
                        throw Error(what + ": 'indices' must be an accessor index");
                    d.indices = index_of(ix.get<uint64_t>(), what + ": indices");
                    prims[p].erase("indices");
                    changed = true;
                }
                draco_.push_back(std::move(d));
            }
        }
    }
    if (!changed) return true;
    // The rewritten JSON; a .glb's JSON chunk padded with spaces, the chunks after it kept.
    std::string out = doc.dump();
    if (!binary) {
        bytes.assign(out.begin(), out.end());
        return true;
    }
    while (out.size() % 4 != 0) out.push_back(' ');
    std::vector<unsigned char> glb(bytes.begin(), bytes.begin() + 12);
    const uint32_t chunk = uint32_t(out.size()), type = 0x4E4F534Au;
    glb.resize(20);
    std::memcpy(glb.data() + 12, &chunk, 4);
    std::memcpy(glb.data() + 16, &type, 4);
    glb.insert(glb.end(), out.begin(), out.end());
    glb.insert(glb.end(), bytes.begin() + 20 + std::ptrdiff_t(length), bytes.end());
    const uint64_t total = glb.size();
    if (total > 0xffffffffu) throw Error("the rewritten .glb exceeds 4 GiB");
    const uint32_t total32 = uint32_t(total);
    std::memcpy(glb.data() + 8, &total32, 4);
    bytes.swap(glb);
    return true;
}

void GltfCompression::decode(tg::Model& model) const {
    if (!meshopt_views_.empty() || !fallbacks_.empty()) decode_meshopt(model);
    if (!draco_.empty()) decode_draco(model);
}

void GltfCompression::decode_meshopt(tg::Model& model) const {
#if !defined(MCPT_WITH_MESHOPT)
    (void)model;
    throw Error(std::string("the file uses ") + kMeshoptCompression +
                ", and this build has no meshoptimizer decoder (Debian: libmeshoptimizer-dev)");
#else
    // Fallback buffers at their real size (zeros), within the budget.
    const uint64_t budget = std::min(kMaxDecodedBytes, host_memory_available() / 2);
    uint64_t total = 0;
    for (const FallbackBuffer& f : fallbacks_) {
        total += f.length;
        if (f.length > kMaxDecodedBytes || total > budget)
            throw Error("buffer " + std::to_string(f.buffer) + " (" + kMeshoptCompression +
                        " fallback) of " + std::to_string(f.length) +
                        " bytes: decoded buffers exceed " + human_bytes(budget));
        model.buffers[size_t(f.buffer)].data.assign(size_t(f.length), 0);
    }
    for (const MeshoptView& m : meshopt_views_) {
        const std::string what =
            "bufferView " + std::to_string(m.view) + " (" + kMeshoptCompression + ")";
        // The compressed stream inside its buffer.
        if (m.buffer < 0 || size_t(m.buffer) >= model.buffers.size())
            throw Error(what + ": buffer " + std::to_string(m.buffer) + " out of range");
        const std::vector<unsigned char>& src = model.buffers[size_t(m.buffer)].data;
        if (m.offset > src.size() || m.length > src.size() - m.offset)
            throw Error(what + ": the compressed stream (" + std::to_string(m.length) +
                        " bytes at " + std::to_string(m.offset) + ") lies outside buffer " +
                        std::to_string(m.buffer) + " (" + std::to_string(src.size()) + " bytes)");
        // The decoded elements must fill the view: count x byteStride bytes.
        uint64_t room = 0;
        unsigned char* dst = view_bytes(model, m.view, room, what);
        if (m.stride == 0 || m.count > room / m.stride)
            throw Error(what + ": " + std::to_string(m.count) + " elements of " +
                        std::to_string(m.stride) + " bytes do not fit the view's " +
                        std::to_string(room) + " bytes");
        const unsigned char* in = src.data() + m.offset;
        const size_t count = size_t(m.count), stride = size_t(m.stride), n = size_t(m.length);
        int rc = 0;
        if (m.mode == "ATTRIBUTES") {
            if (stride % 4 != 0 || stride > 256)
                throw Error(what + ": ATTRIBUTES byteStride must be a multiple of 4, at most 256");
            rc = meshopt_decodeVertexBuffer(dst, count, stride, in, n);
        } else if (m.mode == "TRIANGLES" || m.mode == "INDICES") {
            if (stride != 2 && stride != 4)
                throw Error(what + ": " + m.mode + " byteStride must be 2 or 4");
            if (m.mode == "TRIANGLES" && count % 3 != 0)
                throw Error(what + ": TRIANGLES count must be a multiple of 3");
            if (m.filter != "NONE") throw Error(what + ": " + m.mode + " takes no filter");
            rc = m.mode == "TRIANGLES" ? meshopt_decodeIndexBuffer(dst, count, stride, in, n)
                                       : meshopt_decodeIndexSequence(dst, count, stride, in, n);
        } else {
            throw Error(what + ": unknown mode '" + m.mode + "' (ATTRIBUTES, TRIANGLES, INDICES)");
        }
        if (rc != 0)
            throw Error(what + ": the " + m.mode + " stream does not decode (meshoptimizer " +
                        "error " + std::to_string(rc) + ": truncated or corrupt)");
        // Filters, in place.
        if (m.filter == "OCTAHEDRAL") {
            if (stride != 4 && stride != 8)
                throw Error(what + ": OCTAHEDRAL filter needs byteStride 4 or 8");
            meshopt_decodeFilterOct(dst, count, stride);
        } else if (m.filter == "QUATERNION") {
            if (stride != 8) throw Error(what + ": QUATERNION filter needs byteStride 8");
            meshopt_decodeFilterQuat(dst, count, stride);
        } else if (m.filter == "EXPONENTIAL") {
            if (stride % 4 != 0)
                throw Error(what + ": EXPONENTIAL filter needs a byteStride multiple of 4");
            meshopt_decodeFilterExp(dst, count, stride);
        } else if (m.filter != "NONE") {
            throw Error(what + ": unknown filter '" + m.filter + "'");
        }
    }
#endif
}

#if defined(MCPT_WITH_DRACO)
namespace {

// A new buffer holding `data`, a buffer view over it, and the view's index.
int add_view(tg::Model& model, std::vector<unsigned char> data) {
    tg::BufferView bv;
    bv.buffer = int(model.buffers.size());
    bv.byteOffset = 0;
    bv.byteLength = data.size();
    tg::Buffer b;
    b.data = std::move(data);
    model.buffers.push_back(std::move(b));
    model.bufferViews.push_back(bv);
    return int(model.bufferViews.size() - 1);
}

template <class T>
bool convert_points(const draco::Mesh& mesh, const draco::PointAttribute& a, int components,
                    std::vector<unsigned char>& out) {
    out.resize(size_t(mesh.num_points()) * size_t(components) * sizeof(T));
    T* p = reinterpret_cast<T*>(out.data());
    for (draco::PointIndex i(0); i < mesh.num_points(); ++i) {
        const draco::AttributeValueIndex v = a.mapped_index(i);
        if (v.value() >= a.size()) return false;
        if (!a.ConvertValue<T>(v, int8_t(components), p + size_t(i.value()) * size_t(components)))
            return false;
    }
    return true;
}

}  // namespace
#endif

void GltfCompression::decode_draco(tg::Model& model) const {
#if !defined(MCPT_WITH_DRACO)
    (void)model;
    throw Error(std::string("the file uses ") + kDracoCompression +
                ", and this build has no Draco decoder (Debian: libdraco-dev)");
#else
    uint64_t total = 0;
    const uint64_t budget = std::min(kMaxDecodedBytes, host_memory_available() / 2);
    for (const DracoPrimitive& d : draco_) {
        const std::string what = "mesh " + std::to_string(d.mesh) + " primitive " +
                                 std::to_string(d.primitive) + " (" + kDracoCompression + ")";
        if (size_t(d.mesh) >= model.meshes.size() ||
            size_t(d.primitive) >= model.meshes[size_t(d.mesh)].primitives.size())
            throw Error(what + ": not in the parsed model");
        tg::Primitive& prim = model.meshes[size_t(d.mesh)].primitives[size_t(d.primitive)];
        if (prim.mode != TINYGLTF_MODE_TRIANGLES && prim.mode != -1)
            throw Error(what + ": only TRIANGLES primitives are decoded");
        // The accessors the decoded data will fill: their counts bound the decoder's output.
        const auto accessor = [&](int index, const std::string& role) -> tg::Accessor& {
            if (index < 0 || size_t(index) >= model.accessors.size())
                throw Error(what + ": " + role + " accessor " + std::to_string(index) +
                            " out of range");
            return model.accessors[size_t(index)];
        };
        // Decode.
        uint64_t length = 0;
        const unsigned char* stream = view_bytes(model, d.view, length, what);
        draco::DecoderBuffer buffer;
        buffer.Init(reinterpret_cast<const char*>(stream), size_t(length));
        draco::Decoder decoder;
        auto decoded = decoder.DecodeMeshFromBuffer(&buffer);
        if (!decoded.ok())
            throw Error(what + ": the stream does not decode (Draco: " +
                        decoded.status().error_msg_string() + ")");
        const std::unique_ptr<draco::Mesh>& mesh = decoded.value();
        const uint64_t points = mesh->num_points(), corners = 3 * uint64_t(mesh->num_faces());
        if (points > kMaxDracoElements || corners > kMaxDracoElements)
            throw Error(what + ": " + std::to_string(points) + " vertices and " +
                        std::to_string(corners) + " indices decoded: more than 2^28");
        // Attributes, each in its accessor's component type and element size.
        for (const auto& [name, id] : d.attributes) {
            const auto it = prim.attributes.find(name);
            if (it == prim.attributes.end())
                throw Error(what + ": Draco attribute " + name + " is not an attribute of the " +
                            "primitive");
            tg::Accessor& a = accessor(it->second, name);
            const draco::PointAttribute* pa = mesh->GetAttributeByUniqueId(uint32_t(id));
            if (!pa)
                throw Error(what + ": the stream has no attribute of id " + std::to_string(id));
            if (!pa->is_mapping_identity() && pa->indices_map_size() < points)
                throw Error(what + ": attribute " + name + " maps fewer points than the mesh has");
            if (a.count != points)
                throw Error(what + ": " + name + " decoded " + std::to_string(points) +
                            " vertices, its accessor says " + std::to_string(a.count));
            const int components = tg::GetNumComponentsInType(uint32_t(a.type));
            if (components < 1 || components > 4)
                throw Error(what + ": " + name + " must be SCALAR or VEC2-4");
            std::vector<unsigned char> data;
            bool ok = false;
            switch (a.componentType) {
                case TINYGLTF_COMPONENT_TYPE_FLOAT:
                    ok = convert_points<float>(*mesh, *pa, components, data);
                    break;
                case TINYGLTF_COMPONENT_TYPE_BYTE:
                    ok = convert_points<int8_t>(*mesh, *pa, components, data);
                    break;
                case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE:
                    ok = convert_points<uint8_t>(*mesh, *pa, components, data);
                    break;
                case TINYGLTF_COMPONENT_TYPE_SHORT:
                    ok = convert_points<int16_t>(*mesh, *pa, components, data);
                    break;
                case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT:
                    ok = convert_points<uint16_t>(*mesh, *pa, components, data);
                    break;
                default:
                    throw Error(what + ": " + name + " has an unsupported component type");
            }
            if (!ok) throw Error(what + ": attribute " + name + " does not convert");
            total += data.size();
            if (total > budget) throw Error(what + ": decoded data exceed " + human_bytes(budget));
            a.sparse.isSparse = false;
            a.byteOffset = 0;
            a.bufferView = add_view(model, std::move(data));
        }
        // Indices as 32-bit integers, into the accessor set aside (or a new one).
        std::vector<unsigned char> idx(size_t(corners) * 4);
        for (draco::FaceIndex f(0); f < mesh->num_faces(); ++f)
            for (int k = 0; k < 3; ++k) {
                const uint32_t v = mesh->face(f)[k].value();
                std::memcpy(idx.data() + (size_t(f.value()) * 3 + size_t(k)) * 4, &v, 4);
            }
        total += idx.size();
        if (total > budget) throw Error(what + ": decoded data exceed " + human_bytes(budget));
        if (d.indices >= 0) {
            tg::Accessor& a = accessor(d.indices, "index");
            if (a.count != corners)
                throw Error(what + ": decoded " + std::to_string(corners) +
                            " indices, the accessor says " + std::to_string(a.count));
            prim.indices = d.indices;
        } else {
            model.accessors.emplace_back();
            prim.indices = int(model.accessors.size() - 1);
        }
        tg::Accessor& a = model.accessors[size_t(prim.indices)];
        a.count = size_t(corners), a.type = TINYGLTF_TYPE_SCALAR;
        a.componentType = TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT;
        a.sparse.isSparse = false;
        a.byteOffset = 0;
        a.bufferView = add_view(model, std::move(idx));
    }
#endif
}

}  // namespace mcpt
