// Compressed glTF made here with the libraries' own encoders (meshoptimizer, Draco, libwebp):
// the loader decodes each exactly, and refuses a hostile stream (truncated, miscounted,
// out of its buffer, lying about its size) with an error naming the part and the extension.
#include "common/scene/gltf_compression.h"

#include <gtest/gtest.h>

#include <cstring>
#include <functional>
#include <string>
#include <vector>

#include "common/io/texture_image.h"
#include "tests/gltf_builder.h"

#if defined(MCPT_WITH_MESHOPT)
#include <meshoptimizer.h>
#endif
#if defined(MCPT_WITH_DRACO)
#include <draco/compression/encode.h>
#include <draco/mesh/mesh.h>
#endif
#if defined(MCPT_WITH_WEBP)
#include <webp/encode.h>
#endif

namespace mcpt {
namespace {

using namespace gltf_test;

const std::vector<uint16_t> kQuadIndices = {0, 1, 2, 0, 2, 3};

#if defined(MCPT_WITH_MESHOPT) || defined(MCPT_WITH_DRACO)
// The unit quad's two triangles, as quad_gltf's.
void expect_quad(const Scene& s) {
    ASSERT_EQ(s.triangles.size(), 2u);
    expect_vec(s.triangles[0].v0, kQuad[0]);
    expect_vec(s.triangles[0].v1, kQuad[1]);
    expect_vec(s.triangles[0].v2, kQuad[2]);
    expect_vec(s.triangles[1].v2, kQuad[3]);
}
#endif

#if defined(MCPT_WITH_MESHOPT)
// The quad with positions and indices meshopt-encoded in buffer 0 and decoded into a fallback
// buffer 1 of 48 + 12 bytes. `edit` changes the document before it is written.
std::string meshopt_quad(const std::string& name, const std::function<void(json&)>& edit = {}) {
    Gltf g;
    std::vector<unsigned char> vb(meshopt_encodeVertexBufferBound(4, 12));
    vb.resize(meshopt_encodeVertexBuffer(vb.data(), vb.size(), kQuad.data(), 4, 12));
    const std::vector<unsigned> idx(kQuadIndices.begin(), kQuadIndices.end());
    std::vector<unsigned char> ib(meshopt_encodeIndexBufferBound(6, 4));
    ib.resize(meshopt_encodeIndexBuffer(ib.data(), ib.size(), idx.data(), 6));
    // The compressed streams through the builder's buffer 0 (views 0 and 1, unused).
    g.view(vb.data(), vb.size());
    const size_t ib_offset = g.bin.size() + (4 - g.bin.size() % 4) % 4;
    g.view(ib.data(), ib.size());
    const auto meshopt = [](size_t offset, size_t length, int stride, int count, const char* mode) {
        return json{{"EXT_meshopt_compression",
                     {{"buffer", 0},
                      {"byteOffset", offset},
                      {"byteLength", length},
                      {"byteStride", stride},
                      {"count", count},
                      {"mode", mode}}}};
    };
    const int pv =
        g.push("bufferViews", {{"buffer", 1},
                               {"byteOffset", 0},
                               {"byteLength", 48},
                               {"byteStride", 12},
                               {"extensions", meshopt(0, vb.size(), 12, 4, "ATTRIBUTES")}});
    const int iv =
        g.push("bufferViews", {{"buffer", 1},
                               {"byteOffset", 48},
                               {"byteLength", 12},
                               {"extensions", meshopt(ib_offset, ib.size(), 2, 6, "TRIANGLES")}});
    const int pos = g.accessor(pv, kFloat, 4, "VEC3");
    const int ind = g.accessor(iv, kU16, 6, "SCALAR");
    g.root({{"mesh", g.mesh(pos, ind, g.emissive_material())}});
    json doc = {{"extensionsUsed", {"EXT_meshopt_compression"}},
                {"extensionsRequired", {"EXT_meshopt_compression"}}};
    json fallback = {{"byteLength", 60},
                     {"extensions", {{"EXT_meshopt_compression", {{"fallback", true}}}}}};
    json d = g.doc;
    for (const auto& [k, v] : doc.items()) d[k] = v;
    d["buffers"] = g.finished()["buffers"];
    d["buffers"].push_back(fallback);
    if (edit) edit(d);
    const fs::path path = temp_dir() / name;
    write_file(path, d.dump(1));
    return path.string();
}

TEST(GltfCompression, MeshoptQuadDecodesExactly) {
    const Scene s = load_gltf(meshopt_quad("meshopt.gltf"));
    expect_quad(s);
    EXPECT_TRUE(s.warnings.empty()) << ::testing::PrintToString(s.warnings);
    EXPECT_EQ(s.extensions, std::vector<std::string>{"EXT_meshopt_compression"});
}

TEST(GltfCompression, HostileMeshoptStreamsAreRefused) {
    const auto error = [](const std::string& name, const std::function<void(json&)>& edit) {
        return load_error(meshopt_quad(name, edit));
    };
    const auto ext = [](json& d, int view) -> json& {
        return d["bufferViews"][view]["extensions"]["EXT_meshopt_compression"];
    };
    // Truncated: half the vertex stream.
    std::string e = error("mo_truncated.gltf", [&](json& d) {
        ext(d, 2)["byteLength"] = ext(d, 2)["byteLength"].get<int>() / 2;
    });
    EXPECT_NE(e.find("bufferView 2 (EXT_meshopt_compression): the ATTRIBUTES stream does not "
                     "decode"),
              std::string::npos)
        << e;
    // More elements than the view holds, a stream past its buffer, a stride the codec lacks.
    e = error("mo_count.gltf", [&](json& d) { ext(d, 2)["count"] = 1000; });
    EXPECT_NE(e.find("1000 elements of 12 bytes do not fit"), std::string::npos) << e;
    e = error("mo_outside.gltf", [&](json& d) { ext(d, 3)["byteOffset"] = 1 << 20; });
    EXPECT_NE(e.find("lies outside buffer 0"), std::string::npos) << e;
    e = error("mo_stride.gltf", [&](json& d) { ext(d, 2)["byteStride"] = 6; });
    EXPECT_NE(e.find("multiple of 4"), std::string::npos) << e;
    e = error("mo_mode.gltf", [&](json& d) { ext(d, 3)["mode"] = "STRIPS"; });
    EXPECT_NE(e.find("unknown mode 'STRIPS'"), std::string::npos) << e;
    // A fallback buffer far larger than any decoded data may be.
    e = error("mo_huge.gltf", [&](json& d) { d["buffers"][1]["byteLength"] = 1ull << 40; });
    EXPECT_NE(e.find("decoded buffers exceed"), std::string::npos) << e;
}
#endif

#if defined(MCPT_WITH_DRACO)
// The quad as a Draco stream (sequential encoding keeps the point order), under `edit`.
std::string draco_quad(const std::string& name, const std::function<void(json&)>& edit = {},
                       size_t keep = SIZE_MAX) {
    draco::Mesh mesh;
    mesh.set_num_points(4);
    draco::GeometryAttribute ga;
    ga.Init(draco::GeometryAttribute::POSITION, nullptr, 3, draco::DT_FLOAT32, false, 12, 0);
    const int att = mesh.AddAttribute(ga, true, 4);
    for (int i = 0; i < 4; ++i)
        mesh.attribute(att)->SetAttributeValue(draco::AttributeValueIndex(i), &kQuad[size_t(i)]);
    mesh.AddFace({draco::PointIndex(0), draco::PointIndex(1), draco::PointIndex(2)});
    mesh.AddFace({draco::PointIndex(0), draco::PointIndex(2), draco::PointIndex(3)});
    draco::Encoder encoder;
    encoder.SetEncodingMethod(draco::MESH_SEQUENTIAL_ENCODING);
    draco::EncoderBuffer out;
    EXPECT_TRUE(encoder.EncodeMeshToBuffer(mesh, &out).ok());
    Gltf g;
    const int view = g.view(out.data(), std::min(out.size(), keep));
    const int pos =
        g.push("accessors", {{"componentType", kFloat}, {"count", 4}, {"type", "VEC3"}});
    const int ind =
        g.push("accessors", {{"componentType", kU16}, {"count", 6}, {"type", "SCALAR"}});
    const int mesh_index = g.mesh(pos, ind, g.emissive_material());
    g.doc["meshes"][mesh_index]["primitives"][0]["extensions"] = {
        {"KHR_draco_mesh_compression",
         {{"bufferView", view}, {"attributes", {{"POSITION", mesh.attribute(att)->unique_id()}}}}}};
    g.root({{"mesh", mesh_index}});
    g.doc["extensionsUsed"] = {"KHR_draco_mesh_compression"};
    g.doc["extensionsRequired"] = {"KHR_draco_mesh_compression"};
    if (edit) edit(g.doc);
    return g.write(name);
}

TEST(GltfCompression, DracoQuadDecodesExactly) {
    const Scene s = load_gltf(draco_quad("draco.gltf"));
    expect_quad(s);
    EXPECT_TRUE(s.warnings.empty()) << ::testing::PrintToString(s.warnings);
}

TEST(GltfCompression, HostileDracoStreamsAreRefused) {
    const std::string what = "mesh 0 primitive 0 (KHR_draco_mesh_compression): ";
    std::string e = load_error(draco_quad("draco_truncated.gltf", {}, 20));
    EXPECT_NE(e.find(what + "the stream does not decode (Draco:"), std::string::npos) << e;
    e = load_error(draco_quad("draco_count.gltf", [](json& d) { d["accessors"][0]["count"] = 5; }));
    EXPECT_NE(e.find(what + "POSITION decoded 4 vertices, its accessor says 5"), std::string::npos)
        << e;
    e = load_error(draco_quad("draco_id.gltf", [](json& d) {
        d["meshes"][0]["primitives"][0]["extensions"]["KHR_draco_mesh_compression"]["attributes"]
         ["POSITION"] = 7;
    }));
    EXPECT_NE(e.find(what + "the stream has no attribute of id 7"), std::string::npos) << e;
    e = load_error(draco_quad("draco_view.gltf", [](json& d) {
        d["meshes"][0]["primitives"][0]["extensions"]["KHR_draco_mesh_compression"]["bufferView"] =
            9;
    }));
    EXPECT_NE(e.find(what + "bufferView 9 out of range"), std::string::npos) << e;
    e = load_error(
        draco_quad("draco_indices.gltf", [](json& d) { d["accessors"][1]["count"] = 9; }));
    EXPECT_NE(e.find(what + "decoded 6 indices, the accessor says 9"), std::string::npos) << e;
}
#endif

#if defined(MCPT_WITH_WEBP)
// A 2x2 lossless WebP of four colours.
std::vector<unsigned char> webp_2x2() {
    const uint8_t rgba[16] = {255, 0, 0, 255, 0, 255, 0, 255, 0, 0, 255, 255, 255, 255, 255, 255};
    uint8_t* out = nullptr;
    const size_t n = WebPEncodeLosslessRGBA(rgba, 2, 2, 8, &out);
    std::vector<unsigned char> bytes(out, out + n);
    WebPFree(out);
    return bytes;
}

std::string webp_quad(const std::string& name, const std::vector<unsigned char>& webp) {
    Gltf g = quad_gltf();
    g.doc["images"] = {{{"uri", "data:image/webp;base64," + base64(webp)}}};
    g.doc["textures"] = {{{"extensions", {{"EXT_texture_webp", {{"source", 0}}}}}}};
    g.doc["materials"][0]["emissiveTexture"] = {{"index", 0}};
    g.doc["extensionsUsed"] = {"EXT_texture_webp"};
    g.doc["extensionsRequired"] = {"EXT_texture_webp"};
    return g.write(name);
}

TEST(GltfCompression, WebpTextureDecodesExactly) {
    const std::vector<unsigned char> webp = webp_2x2();
    const Scene s = load_gltf(webp_quad("webp.gltf", webp));
    ASSERT_EQ(s.textures.size(), 1u);
    const uint8_t rgba[16] = {255, 0, 0, 255, 0, 255, 0, 255, 0, 0, 255, 255, 255, 255, 255, 255};
    EXPECT_EQ(s.textures[0].rgba, texture_from_rgba8("", 2, 2, rgba, true).rgba);
    EXPECT_TRUE(s.warnings.empty()) << ::testing::PrintToString(s.warnings);
}

TEST(GltfCompression, HostileWebpImagesAreRefused) {
    const std::vector<unsigned char> webp = webp_2x2();
    // Truncated.
    std::string e = load_error(webp_quad("webp_cut.gltf", {webp.begin(), webp.begin() + 24}));
    EXPECT_NE(e.find("emissiveTexture: image 0: WebP"), std::string::npos) << e;
    // A header that claims 16384 x 16384 texels: refused before anything is decoded.
    std::vector<unsigned char> big = webp;
    ASSERT_EQ(std::memcmp(big.data() + 12, "VP8L", 4), 0);
    const uint32_t size = 16383u | (16383u << 14);  // width - 1, height - 1 (14 bits each)
    big[21] = uint8_t(size), big[22] = uint8_t(size >> 8), big[23] = uint8_t(size >> 16);
    big[24] = uint8_t((big[24] & 0xf0) | ((size >> 24) & 0x0f));
    e = load_error(webp_quad("webp_big.gltf", big));
    EXPECT_NE(e.find("16384x16384 texels exceeds"), std::string::npos) << e;
}
#endif

// tests/data's box as gltfpack -cc (meshopt, quantized: 14-bit positions) and gltf-transform
// draco wrote it: the same triangles, each corner within the quantization step.
TEST(GltfCompression, PipelineFilesMatchTheirOriginal) {
    if (!GltfCompression::has_meshopt() || !GltfCompression::has_draco())
        GTEST_SKIP() << "this build lacks a decoder";
    const std::string dir = MCPT_TEST_DATA_DIR;
    const Scene original = load_gltf(dir + "/cube_box.glb");
    Bounds box;
    for (const Triangle& t : original.triangles)
        box.extend(t.v0), box.extend(t.v1), box.extend(t.v2);
    const float step = glm::length(box.max - box.min) / 16383.f;
    for (const char* name : {"cube_box_meshopt.glb", "cube_box_draco.glb"}) {
        const Scene s = load_gltf(dir + "/" + name);
        ASSERT_EQ(s.triangles.size(), original.triangles.size()) << name;
        // Compressors reorder triangles: each corner's nearest corner of the original.
        for (const Triangle& t : s.triangles)
            for (const glm::vec3& v : {t.v0, t.v1, t.v2}) {
                float nearest = 1e30f;
                for (const Triangle& o : original.triangles)
                    for (const glm::vec3& w : {o.v0, o.v1, o.v2})
                        nearest = std::min(nearest, glm::length(v - w));
                EXPECT_LE(nearest, step) << name;
            }
    }
}

// A build without a decoder names the package to install.
TEST(GltfCompression, MissingDecodersAreNamed) {
    if (GltfCompression::has_draco()) GTEST_SKIP() << "this build decodes Draco";
    Gltf g = quad_gltf();
    g.doc["meshes"][0]["primitives"][0]["extensions"] = {
        {"KHR_draco_mesh_compression", {{"bufferView", 0}, {"attributes", json::object()}}}};
    g.doc["extensionsUsed"] = {"KHR_draco_mesh_compression"};
    const std::string e = load_error(g.write("no_draco.gltf"));
    EXPECT_NE(e.find("libdraco-dev"), std::string::npos) << e;
}

}  // namespace
}  // namespace mcpt
