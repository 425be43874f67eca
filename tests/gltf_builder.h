// Test helpers for glTF files built in memory: a document around one binary buffer, written
// as .gltf (data URI) or .glb into a per-process scratch folder, and checks on what loads.
#pragma once

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <glm/glm.hpp>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "common/error.h"
#include "common/scene/gltf_loader.h"
#include "common/scene/scene.h"

namespace mcpt::gltf_test {

namespace fs = std::filesystem;
using nlohmann::json;

constexpr int kU8 = 5121, kU16 = 5123, kU32 = 5125, kFloat = 5126;
constexpr double kQuarterPi = 0.78539816339744831;

inline std::string base64(const std::vector<unsigned char>& in) {
    static const char* table = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    std::string out;
    for (size_t i = 0; i < in.size(); i += 3) {
        const uint32_t n = uint32_t(in[i]) << 16 | (i + 1 < in.size() ? in[i + 1] << 8 : 0) |
                           (i + 2 < in.size() ? in[i + 2] : 0);
        out += table[n >> 18 & 63];
        out += table[n >> 12 & 63];
        out += i + 1 < in.size() ? table[n >> 6 & 63] : '=';
        out += i + 2 < in.size() ? table[n & 63] : '=';
    }
    return out;
}

// A per-process scratch directory.
inline fs::path temp_dir() {
    const fs::path dir = fs::temp_directory_path() / ("mcpt_gltf_test_" + std::to_string(getpid()));
    fs::create_directories(dir);
    return dir;
}

// Removes the scratch directory after the last test.
class ScratchCleanup : public ::testing::Environment {
  public:
    void TearDown() override {
        std::error_code ec;
        fs::remove_all(temp_dir(), ec);
    }
};
inline const ::testing::Environment* const kCleanup =
    ::testing::AddGlobalTestEnvironment(new ScratchCleanup);

inline void write_file(const fs::path& path, const std::string& bytes) {
    std::ofstream out(path, std::ios::binary);
    out.write(bytes.data(), std::streamsize(bytes.size()));
}

// Builds a glTF document around one binary buffer.
struct Gltf {
    json doc = {
        {"asset", {{"version", "2.0"}}}, {"scenes", {{{"nodes", json::array()}}}}, {"scene", 0}};
    std::vector<unsigned char> bin;

    int push(const char* key, const json& item) {
        doc[key].push_back(item);
        return int(doc[key].size() - 1);
    }
    int view(const void* data, size_t size, size_t stride = 0) {
        while (bin.size() % 4) bin.push_back(0);
        json v = {{"buffer", 0}, {"byteOffset", bin.size()}, {"byteLength", size}};
        if (stride) v["byteStride"] = stride;
        bin.insert(bin.end(), (const unsigned char*)data, (const unsigned char*)data + size);
        return push("bufferViews", v);
    }
    int accessor(int view, int component, size_t count, const char* type, size_t offset = 0) {
        return push("accessors", {{"bufferView", view},
                                  {"componentType", component},
                                  {"count", count},
                                  {"type", type},
                                  {"byteOffset", offset}});
    }
    int positions(const std::vector<glm::vec3>& p) {
        return accessor(view(p.data(), p.size() * 12), kFloat, p.size(), "VEC3");
    }
    template <class T>
    int indices(const std::vector<T>& i, int component) {
        return accessor(view(i.data(), i.size() * sizeof(T)), component, i.size(), "SCALAR");
    }
    int mesh(int pos, int idx = -1, int material = -1) {
        json prim = {{"attributes", {{"POSITION", pos}}}};
        if (idx >= 0) prim["indices"] = idx;
        if (material >= 0) prim["material"] = material;
        return push("meshes", {{"primitives", {prim}}});
    }
    int root(json node) {
        const int n = push("nodes", node);
        doc["scenes"][0]["nodes"].push_back(n);
        return n;
    }
    int emissive_material() {
        return push("materials", {{"emissiveFactor", {1, 1, 1}},
                                  {"pbrMetallicRoughness", {{"metallicFactor", 0}}}});
    }
    json finished() const {
        json d = doc;
        d["buffers"] = {{{"byteLength", bin.size()},
                         {"uri", "data:application/octet-stream;base64," + base64(bin)}}};
        return d;
    }
    std::string write(const std::string& name) const {
        const fs::path path = temp_dir() / name;
        write_file(path, finished().dump(1));
        return path.string();
    }
    // GLB: 12-byte header, a JSON chunk padded with spaces, a BIN chunk padded with zeros.
    std::string write_glb(const std::string& name) const {
        json d = doc;
        std::vector<unsigned char> b = bin;
        while (b.size() % 4) b.push_back(0);
        d["buffers"] = {{{"byteLength", bin.size()}}};
        std::string js = d.dump();
        while (js.size() % 4) js += ' ';
        std::string out = "glTF";
        auto u32 = [&out](uint32_t v) { out.append(reinterpret_cast<const char*>(&v), 4); };
        u32(2);
        u32(uint32_t(12 + 8 + js.size() + 8 + b.size()));
        u32(uint32_t(js.size()));
        u32(0x4E4F534A);  // JSON
        out += js;
        u32(uint32_t(b.size()));
        u32(0x004E4942);  // BIN
        out.append(reinterpret_cast<const char*>(b.data()), b.size());
        const fs::path path = temp_dir() / name;
        write_file(path, out);
        return path.string();
    }
};

inline const std::vector<glm::vec3> kQuad = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}};

// The unit quad in z = 0 (facing +z), indexed with the given type, under one node.
inline Gltf quad_gltf(json node = json::object(), int index_type = kU16) {
    Gltf g;
    const int pos = g.positions(kQuad);
    int idx = -1;
    if (index_type == kU8) idx = g.indices(std::vector<uint8_t>{0, 1, 2, 0, 2, 3}, kU8);
    if (index_type == kU16) idx = g.indices(std::vector<uint16_t>{0, 1, 2, 0, 2, 3}, kU16);
    if (index_type == kU32) idx = g.indices(std::vector<uint32_t>{0, 1, 2, 0, 2, 3}, kU32);
    node["mesh"] = g.mesh(pos, idx, g.emissive_material());
    g.root(node);
    return g;
}

// The message of the mcpt::Error that load_gltf throws ("" if none).
inline std::string load_error(const std::string& path) {
    try {
        load_gltf(path);
    } catch (const Error& e) {
        return e.what();
    }
    return "";
}

inline void expect_vec(const glm::vec3& got, const glm::vec3& want, float eps = 1e-5f) {
    EXPECT_NEAR(got.x, want.x, eps);
    EXPECT_NEAR(got.y, want.y, eps);
    EXPECT_NEAR(got.z, want.z, eps);
}

inline bool has_warning(const Scene& s, const std::string& text) {
    for (const std::string& w : s.warnings)
        if (w.find(text) != std::string::npos) return true;
    return false;
}

}  // namespace mcpt::gltf_test
