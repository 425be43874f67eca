// The glTF loader's buffer data (gltf_loader_internal.h): accessors checked against their
// views and buffers, decoded (floats, normalized or plain integers, sparse substitutions) into
// positions, normals, texture coordinates and indices.
#include <algorithm>
#include <cstring>
#include <sstream>

#include "common/scene/gltf_loader_internal.h"

namespace mcpt {
namespace gltf {
namespace {

// Elements of an accessor without a bufferView (zeros but for its sparse values): 2^24, 192 MiB
// as positions; no real scene comes near it without data behind it.
constexpr size_t kMaxZeroAccessorCount = size_t(1) << 24;

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

}  // namespace

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

std::vector<uint32_t> GltfLoader::read_indices(int accessor, const std::string& where) const {
    const std::string what = where + " index accessor " + std::to_string(accessor);
    const tg::Accessor& a = accessor_at(accessor, what);
    const size_t size = index_size(a.componentType);
    if (size == 0 || a.type != TINYGLTF_TYPE_SCALAR)
        fail(what + ": indices must be SCALAR unsigned byte, short or int");
    return read_accessor<uint32_t>(a, size, what,
                                   [size](const unsigned char* p) { return read_index(p, size); });
}

}  // namespace gltf
}  // namespace mcpt
