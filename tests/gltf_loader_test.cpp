// load_gltf(): small .gltf/.glb files written by the tests (data-URI buffers, hand-built GLB)
// plus the hand-checked files in tests/data/.
#include "common/scene/gltf_loader.h"

#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "common/error.h"
#include "common/io/image_io.h"
#include "common/scene/gltf_compression.h"
#include "common/scene/scene.h"
#include "common/scene/scene_load.h"
#include "tests/gltf_builder.h"

namespace mcpt {
namespace {

using namespace gltf_test;

TEST(GltfLoader, QuadWithTranslationAndScale) {
    const Gltf g = quad_gltf({{"translation", {1, 2, 3}}, {"scale", {2, 2, 2}}});
    Scene s = load_gltf(g.write("trs.gltf"));
    ASSERT_EQ(s.triangles.size(), 2u);
    expect_vec(s.triangles[0].v0, {1, 2, 3});
    expect_vec(s.triangles[0].v1, {3, 2, 3});
    expect_vec(s.triangles[0].v2, {3, 4, 3});
    expect_vec(s.triangles[1].v2, {1, 4, 3});
    EXPECT_EQ(s.name, "trs");
    // No camera in the file: framed from +z.
    EXPECT_TRUE(s.has_camera);
    expect_vec(s.camera.forward, {0, 0, -1});
    EXPECT_GT(s.camera.position.z, 3.f);
    EXPECT_TRUE(s.warnings.empty());
    EXPECT_EQ(validate_scene(s).degenerate_dropped, 0u);
}

TEST(GltfLoader, RotationAndMatrixInAHierarchy) {
    // Parent: translate (0, 0, 5); child: matrix = 90 degrees about z, then translate (10, 0, 0).
    Gltf g = quad_gltf({{"translation", {0, 0, 5}}, {"children", {1}}});
    const json mesh = g.doc["nodes"][0]["mesh"];
    g.doc["nodes"][0].erase("mesh");
    g.push("nodes",
           {{"mesh", mesh}, {"matrix", {0, 1, 0, 0, -1, 0, 0, 0, 0, 0, 1, 0, 10, 0, 0, 1}}});
    Scene s = load_gltf(g.write("matrix.gltf"));
    ASSERT_EQ(s.triangles.size(), 2u);
    expect_vec(s.triangles[0].v0, {10, 0, 5});
    expect_vec(s.triangles[0].v1, {10, 1, 5});  // (1, 0, 0) -> (0, 1, 0) -> +translation
    expect_vec(s.triangles[0].v2, {9, 1, 5});

    // The same rotation as a quaternion (x, y, z, w).
    Scene r =
        load_gltf(quad_gltf({{"rotation", {0, 0, std::sin(kQuarterPi), std::cos(kQuarterPi)}}})
                      .write("q.gltf"));
    expect_vec(r.triangles[0].v1, {0, 1, 0});
}

TEST(GltfLoader, MirroringTransformKeepsFrontSide) {
    Scene s = load_gltf(quad_gltf({{"scale", {-1, 1, 1}}}).write("mirror.gltf"));
    ASSERT_EQ(s.triangles.size(), 2u);
    for (const Triangle& t : s.triangles) {
        const glm::vec3 n = glm::cross(t.v1 - t.v0, t.v2 - t.v0);
        EXPECT_GT(n.z, 0.f);  // the quad still faces +z
    }
}

TEST(GltfLoader, CameraNode) {
    Gltf g = quad_gltf();
    g.push("cameras", {{"type", "orthographic"},
                       {"orthographic", {{"xmag", 1}, {"ymag", 1}, {"znear", 0.1}, {"zfar", 10}}}});
    g.push("cameras", {{"type", "perspective"},
                       {"name", "cam"},
                       {"perspective", {{"yfov", 0.5}, {"znear", 0.1}}}});
    // An orthographic camera first (skipped), then a perspective one under a translated parent,
    // turned 90 degrees about +y so that it looks along -x.
    g.root({{"camera", 0}});
    const int parent = g.root({{"translation", {0, 0, 1}}, {"children", {4}}});
    EXPECT_EQ(parent, 2);
    g.push("nodes", json::object());
    g.push("nodes", {{"camera", 1},
                     {"translation", {0, 1, 4}},
                     {"rotation", {0, std::sin(kQuarterPi), 0, std::cos(kQuarterPi)}}});
    Scene s = load_gltf(g.write("camera.gltf"));
    ASSERT_TRUE(s.has_camera);
    expect_vec(s.camera.position, {0, 1, 5});
    expect_vec(s.camera.forward, {-1, 0, 0});
    expect_vec(s.camera.up, {0, 1, 0});
    EXPECT_FLOAT_EQ(s.camera.yfov, 0.5f);
    EXPECT_TRUE(has_warning(s, "orthographic")) << ::testing::PrintToString(s.warnings);
}

TEST(GltfLoader, MaterialMapping) {
    Gltf g;
    const int pos = g.positions({kQuad[0], kQuad[1], kQuad[2]});
    const json pbr_metal = {{"metallicFactor", 1.0},
                            {"roughnessFactor", 0.01},
                            {"baseColorFactor", {0.9, 0.8, 0.7, 1}}};
    const json no_specular = {{"KHR_materials_specular", {{"specularFactor", 0.0}}}};
    const json mats[] = {
        // 0: emissive with KHR_materials_emissive_strength
        {{"name", "lamp"},
         {"doubleSided", true},
         {"emissiveFactor", {1, 0.5, 0.25}},
         {"pbrMetallicRoughness", {{"metallicFactor", 0}}},
         {"extensions", {{"KHR_materials_emissive_strength", {{"emissiveStrength", 4.0}}}}}},
        // 1: rough glass with an ior
        {{"name", "frosted"},
         {"pbrMetallicRoughness", {{"baseColorFactor", {0.9, 1, 0.9, 1}}, {"metallicFactor", 0}}},
         {"extensions",
          {{"KHR_materials_transmission", {{"transmissionFactor", 1.0}}},
           {"KHR_materials_ior", {{"ior", 1.33}}}}}},
        // 2: mirror (metal of roughness 0.01)
        {{"pbrMetallicRoughness", pbr_metal}},
        // 3: diffuse: a dielectric without a specular layer
        {{"pbrMetallicRoughness", {{"baseColorFactor", {0.2, 0.4, 0.6, 1}}, {"metallicFactor", 0}}},
         {"extensions", no_specular}},
        // 4: rough metal (glTF's defaults: metallic 1)
        {{"name", "brushed"}, {"pbrMetallicRoughness", {{"roughnessFactor", 0.5}}}},
        // 5: weak transmission -> not glass: a dielectric with a half specular layer
        {{"extensions",
          {{"KHR_materials_transmission", {{"transmissionFactor", 0.3}}},
           {"KHR_materials_specular", {{"specularFactor", 0.5}}},
           {"KHR_materials_ior", {{"ior", 1.4}}}}},
         {"pbrMetallicRoughness", {{"metallicFactor", 0}, {"roughnessFactor", 0.25}}}},
    };
    g.doc["extensionsUsed"] = {"KHR_materials_emissive_strength", "KHR_materials_transmission",
                               "KHR_materials_ior", "KHR_materials_specular"};
    for (const json& m : mats) g.push("materials", m);
    json prims = json::array();
    for (int i = 0; i < 6; ++i)
        prims.push_back({{"attributes", {{"POSITION", pos}}}, {"material", i}});
    prims.push_back({{"attributes", {{"POSITION", pos}}}});  // no material
    g.push("meshes", {{"primitives", prims}});
    g.root({{"mesh", 0}});
    Scene s = load_gltf(g.write("materials.gltf"));
    ASSERT_EQ(s.materials.size(), 7u);
    ASSERT_EQ(s.triangles.size(), 7u);

    const Material& lamp = s.materials[s.triangles[0].material];
    EXPECT_EQ(lamp.name, "lamp");
    expect_vec(lamp.emission, {4, 2, 1});
    EXPECT_EQ(lamp.type, MaterialType::Pbr);  // glTF's default dielectric has a specular layer
    EXPECT_TRUE(lamp.two_sided);                // doubleSided: it emits from both faces
    const Material& glass = s.materials[s.triangles[1].material];
    EXPECT_FALSE(glass.two_sided);  // glTF's default: one-sided
    EXPECT_EQ(glass.type, MaterialType::RoughGlass);  // glTF's default roughness is 1
    EXPECT_FLOAT_EQ(glass.ior, 1.33f);
    EXPECT_FLOAT_EQ(glass.roughness, 1.f);
    expect_vec(glass.color, {0.9f, 1, 0.9f});
    const Material& mirror = s.materials[s.triangles[2].material];
    EXPECT_EQ(mirror.type, MaterialType::Mirror);
    expect_vec(mirror.color, {0.9f, 0.8f, 0.7f});
    const Material& diffuse = s.materials[s.triangles[3].material];
    EXPECT_EQ(diffuse.type, MaterialType::Diffuse);
    expect_vec(diffuse.color, {0.2f, 0.4f, 0.6f});
    expect_vec(diffuse.emission, {0, 0, 0});
    const Material& brushed = s.materials[s.triangles[4].material];
    EXPECT_EQ(brushed.type, MaterialType::Pbr);
    EXPECT_FLOAT_EQ(brushed.metallic, 1.f);
    EXPECT_FLOAT_EQ(brushed.roughness, 0.5f);
    const Material& plastic = s.materials[s.triangles[5].material];
    EXPECT_EQ(plastic.type, MaterialType::Pbr);
    EXPECT_FLOAT_EQ(plastic.metallic, 0.f);
    EXPECT_FLOAT_EQ(plastic.roughness, 0.25f);
    EXPECT_FLOAT_EQ(plastic.specular, 0.5f);
    EXPECT_FLOAT_EQ(plastic.ior, 1.4f);
    const Material& fallback = s.materials[s.triangles[6].material];
    EXPECT_EQ(fallback.type, MaterialType::Diffuse);
    expect_vec(fallback.color, glm::vec3(0.8f));
    EXPECT_EQ(s.warnings.size(), 0u) << ::testing::PrintToString(s.warnings);
    EXPECT_EQ(validate_scene(s).degenerate_dropped, 0u);

    // Glass without KHR_materials_ior gets 1.5; a smooth one is the exact dielectric.
    g.doc["materials"][1]["pbrMetallicRoughness"]["roughnessFactor"] = 0.0;
    g.doc["materials"][1]["extensions"].erase("KHR_materials_ior");
    Scene d = load_gltf(g.write("materials_noior.gltf"));
    EXPECT_FLOAT_EQ(d.materials[1].ior, 1.5f);
    EXPECT_EQ(d.materials[1].type, MaterialType::Glass);

    // Blender's exporter writes Specular 0 as specularColorFactor [0, 0, 0]: no specular layer
    // either; a grey colour scales the factor by its mean.
    g.doc["materials"][3]["extensions"]["KHR_materials_specular"] = {
        {"specularColorFactor", {0, 0, 0}}};
    g.doc["materials"][5]["extensions"]["KHR_materials_specular"]["specularColorFactor"] = {
        0.2, 0.4, 0.6};
    Scene c = load_gltf(g.write("materials_specular_color.gltf"));
    EXPECT_EQ(c.materials[3].type, MaterialType::Diffuse);
    EXPECT_FLOAT_EQ(c.materials[5].specular, 0.5f * 0.4f);
}

class GltfIndexTypes : public ::testing::TestWithParam<int> {};

TEST_P(GltfIndexTypes, LoadsTheQuad) {
    Scene s =
        load_gltf(quad_gltf({}, GetParam()).write("idx" + std::to_string(GetParam()) + ".gltf"));
    ASSERT_EQ(s.triangles.size(), 2u);
    expect_vec(s.triangles[1].v0, kQuad[0]);
    expect_vec(s.triangles[1].v1, kQuad[2]);
    expect_vec(s.triangles[1].v2, kQuad[3]);
}

// Unsigned byte, short and int indices.
INSTANTIATE_TEST_SUITE_P(All, GltfIndexTypes, ::testing::Values(kU8, kU16, kU32));

TEST(GltfLoader, NonIndexedInterleavedWithStride) {
    // Positions interleaved with a 3-float normal: byteStride 24, POSITION at offset 0.
    const float data[] = {0, 0, 0, 9, 9, 9, 2, 0, 0, 9, 9, 9, 0, 2, 0, 9, 9, 9};
    Gltf g;
    const int view = g.view(data, sizeof(data), 24);
    const int pos = g.accessor(view, kFloat, 3, "VEC3");
    g.root({{"mesh", g.mesh(pos, -1, g.emissive_material())}});
    Scene s = load_gltf(g.write("stride.gltf"));
    ASSERT_EQ(s.triangles.size(), 1u);
    expect_vec(s.triangles[0].v1, {2, 0, 0});
    expect_vec(s.triangles[0].v2, {0, 2, 0});

    // Stride past the end of the view.
    g.doc["accessors"][0]["byteOffset"] = 16;
    g.doc["accessors"][0]["count"] = 3;
    EXPECT_NE(load_error(g.write("stride_oob.gltf")).find("out of bounds"), std::string::npos);
}

TEST(GltfLoader, SparsePositions) {
    // Base: the quad; sparse: corner 2 moved to (5, 5, 0).
    Gltf g = quad_gltf();
    const uint16_t si[] = {2};
    const float sv[] = {5, 5, 0};
    const int iv = g.view(si, sizeof(si)), vv = g.view(sv, sizeof(sv));
    g.doc["accessors"][0]["sparse"] = {{"count", 1},
                                       {"indices", {{"bufferView", iv}, {"componentType", kU16}}},
                                       {"values", {{"bufferView", vv}}}};
    Scene s = load_gltf(g.write("sparse.gltf"));
    ASSERT_EQ(s.triangles.size(), 2u);
    expect_vec(s.triangles[0].v2, {5, 5, 0});
}

TEST(GltfLoader, BinaryGlb) {
    Gltf g = quad_gltf({{"translation", {0, 0, -1}}});
    Scene s = load_gltf(g.write_glb("quad.glb"));
    ASSERT_EQ(s.triangles.size(), 2u);
    expect_vec(s.triangles[0].v1, {1, 0, -1});
    EXPECT_TRUE(s.materials[0].is_emissive());

    // A truncated GLB is an error naming the file.
    std::ifstream in(g.write_glb("full.glb"), std::ios::binary);
    std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    const fs::path cut = temp_dir() / "truncated.glb";
    write_file(cut, bytes.substr(0, bytes.size() / 2));
    const std::string e = load_error(cut.string());
    EXPECT_NE(e.find("truncated.glb"), std::string::npos) << e;
    EXPECT_NE(e.find("binary"), std::string::npos) << e;
}

TEST(GltfLoader, UnsupportedFeaturesWarnOnce) {
    Gltf g = quad_gltf();
    g.doc["extensionsUsed"] = {"KHR_materials_iridescence", "KHR_materials_anisotropy"};
    g.doc["images"] = {{{"uri", "data:image/png;base64,AAAA"}}};  // never decoded
    g.doc["textures"] = {{{"source", 0}}};
    g.doc["materials"][0]["occlusionTexture"] = {{"index", 0}};
    g.doc["materials"][0]["alphaMode"] = "BLEND";
    // A LINES primitive (skipped) and a morph target.
    g.doc["meshes"][0]["primitives"].push_back({{"attributes", {{"POSITION", 0}}}, {"mode", 1}});
    g.doc["meshes"][0]["primitives"].push_back({{"attributes", {{"POSITION", 0}}}, {"mode", 1}});
    g.doc["meshes"][0]["primitives"][0]["targets"] = {{{"POSITION", 0}}};
    // A skin and an animation.
    g.doc["skins"] = {{{"joints", {0}}}};
    g.doc["animations"] = {{{"channels", json::array()}, {"samplers", json::array()}}};
    Scene s = load_gltf(g.write("warnings.gltf"));
    EXPECT_EQ(s.triangles.size(), 2u);
    for (const char* w : {"KHR_materials_iridescence", "KHR_materials_anisotropy",
                          "occlusion textures are not used", "alphaMode BLEND", "LINES",
                          "morph targets", "skins", "animations"})
        EXPECT_TRUE(has_warning(s, w)) << w << " in " << ::testing::PrintToString(s.warnings);
    EXPECT_EQ(s.warnings.size(), 8u) << ::testing::PrintToString(s.warnings);
}

// A texture whose image file is missing, or is not an image, is an error that names it.
TEST(GltfLoader, BadTextureImagesAreErrors) {
    Gltf g = quad_gltf();
    g.doc["images"] = {{{"uri", "missing.png"}}};
    g.doc["textures"] = {{{"source", 0}}};
    g.doc["materials"][0]["pbrMetallicRoughness"]["baseColorTexture"] = {{"index", 0}};
    std::string e = load_error(g.write("missing_image.gltf"));
    EXPECT_NE(e.find("missing.png"), std::string::npos) << e;
    g.doc["images"] = {{{"uri", "data:image/png;base64,aGVsbG8gd29ybGQ="}}};  // "hello world"
    e = load_error(g.write("not_png.gltf"));
    EXPECT_NE(e.find("not a PNG, JPEG or WebP"), std::string::npos) << e;
    g.doc["materials"][0]["pbrMetallicRoughness"]["baseColorTexture"] = {{"index", 3}};
    e = load_error(g.write("bad_texture_index.gltf"));
    EXPECT_NE(e.find("texture 3 out of range"), std::string::npos) << e;
}

TEST(GltfLoader, MissingFile) {
    const std::string e = load_error("/nonexistent/dir/scene.gltf");
    EXPECT_NE(e.find("/nonexistent/dir/scene.gltf"), std::string::npos) << e;
    EXPECT_NE(e.find("not found"), std::string::npos) << e;
}

TEST(GltfLoader, GarbageAndTruncatedJson) {
    const fs::path garbage = temp_dir() / "garbage.gltf";
    write_file(garbage, "this is { not json");
    std::string e = load_error(garbage.string());
    EXPECT_NE(e.find("garbage.gltf"), std::string::npos) << e;
    EXPECT_NE(e.find("cannot load glTF"), std::string::npos) << e;

    const std::string full = quad_gltf().finished().dump();
    const fs::path cut = temp_dir() / "cut.gltf";
    write_file(cut, full.substr(0, full.size() / 2));
    e = load_error(cut.string());
    EXPECT_NE(e.find("cut.gltf"), std::string::npos) << e;

    // Empty, as a .gltf and a .glb: said once, with the path once.
    for (const char* name : {"empty.gltf", "empty.glb"}) {
        const fs::path empty = temp_dir() / name;
        write_file(empty, "");
        e = load_error(empty.string());
        EXPECT_NE(e.find("empty file (0 bytes)"), std::string::npos) << e;
        EXPECT_EQ(e.find(name), e.rfind(name)) << "the path repeats: " << e;
    }
}

// A .glb whose BIN chunk claims the bytes its own 8-byte header takes: tinygltf copied the
// claimed length from past the end of the data (heap overflow; found by the glTF fuzz target,
// tests/fuzz/regressions/gltf/glb_bin_chunk_overrun.glb). Refused from a file and from memory.
TEST(GltfLoader, GlbChunkRunningPastTheDataIsRefused) {
    std::string json = R"({"asset":{"version":"2.0"},"buffers":[{"byteLength":16}]})";
    while (json.size() % 4) json += ' ';
    std::string glb = "glTF";
    auto put32 = [&](uint32_t v) { glb.append(reinterpret_cast<const char*>(&v), 4); };
    const uint32_t total = uint32_t(12 + 8 + json.size() + 8 + 8);
    put32(2), put32(total), put32(uint32_t(json.size()));
    glb += "JSON" + json;
    put32(16);  // the BIN chunk's length: 16 bytes claimed, 8 present
    glb += std::string("BIN\0", 4) + std::string(8, '\x7f');
    ASSERT_EQ(glb.size(), total);
    const fs::path path = temp_dir() / "bin_overrun.glb";
    write_file(path, glb);
    const std::string expected = "BIN chunk of 16 bytes runs past the end of the file";
    EXPECT_NE(load_error(path.string()).find(expected), std::string::npos)
        << load_error(path.string());
    try {
        load_scene_memory(glb.data(), glb.size());
        ADD_FAILURE() << "the overrunning BIN chunk was accepted from memory";
    } catch (const Error& e) {
        EXPECT_NE(std::string(e.what()).find(expected), std::string::npos) << e.what();
    }
    // Negative control: the same file with the chunk's true length loads as far as its
    // content allows (no geometry: an error about the scene, not the layout).
    glb.replace(12 + 8 + json.size(), 4, std::string("\x08\0\0\0", 4));
    glb.replace(8, 4, std::string(reinterpret_cast<const char*>(&total), 4));
    write_file(path, glb);
    EXPECT_EQ(load_error(path.string()).find("runs past"), std::string::npos)
        << load_error(path.string());
}

// Nodes instancing one mesh multiply its triangles: counted from the accessors before any is
// expanded, and refused with the count and the memory it needs (it allocated 8.8 GB for a 2 MB
// file instancing 100k triangles 1000 times, then threw std::bad_alloc).
TEST(GltfLoader, InstancedTrianglesBeyondTheBudgetAreRefused) {
    const auto file = [&](int instances) {
        json d = quad_gltf(json::object(), 0).finished();  // not indexed
        for (json& a : d["accessors"])
            if (a["type"] == "VEC3") a["count"] = 3 << 20;  // claimed: refused before it is read
        d["nodes"] = json::array();
        d["scenes"][0]["nodes"] = json::array();
        for (int k = 0; k < instances; ++k) {
            d["nodes"].push_back({{"mesh", 0}, {"translation", {0, 0, k}}});
            d["scenes"][0]["nodes"].push_back(k);
        }
        const fs::path path = temp_dir() / ("instanced_" + std::to_string(instances) + ".gltf");
        write_file(path, d.dump());
        return load_error(path.string());
    };
    const std::string e = file(300);  // 3.1e8 triangles: over 2^28 on any host
    EXPECT_NE(e.find("scene too large: 314572800 triangles in 300 mesh instances need about"),
              std::string::npos)
        << e;
    // Negative control: 2 instances pass the count and fail on the data they claim.
    const std::string small = file(2);
    EXPECT_EQ(small.find("scene too large"), std::string::npos) << small;
    EXPECT_NE(small, "") << "the claimed accessor was read";
}

// JSON nested tens of thousands deep (here in extras) is refused before the parser recurses
// through it (it overflowed the stack: signal 11), from a .gltf, a .glb and memory; brackets
// inside strings do not count, and a normal scene's nesting passes.
TEST(GltfLoader, DeepJsonNestingIsRefused) {
    std::string json = quad_gltf().finished().dump();
    const std::string deep = std::string(100000, '[') + std::string(100000, ']');
    std::string nested = json;
    nested.insert(nested.size() - 1, ",\"extras\":" + deep);
    const fs::path gltf = temp_dir() / "deep.gltf";
    write_file(gltf, nested);
    EXPECT_NE(load_error(gltf.string()).find("JSON nested deeper than 256 levels"),
              std::string::npos)
        << load_error(gltf.string());
    // The same JSON as a .glb's JSON chunk (padded to 4 bytes).
    std::string chunk = nested;
    while (chunk.size() % 4) chunk += ' ';
    std::string glb = "glTF";
    auto put32 = [&](uint32_t v) { glb.append(reinterpret_cast<const char*>(&v), 4); };
    put32(2), put32(uint32_t(12 + 8 + chunk.size())), put32(uint32_t(chunk.size()));
    glb += "JSON" + chunk;
    const fs::path glb_path = temp_dir() / "deep.glb";
    write_file(glb_path, glb);
    EXPECT_NE(load_error(glb_path.string()).find("nested deeper"), std::string::npos)
        << load_error(glb_path.string());
    try {
        load_scene_memory(glb.data(), glb.size());
        ADD_FAILURE() << "deep JSON from memory was accepted";
    } catch (const Error& e) {
        EXPECT_NE(std::string(e.what()).find("nested deeper"), std::string::npos) << e.what();
    }
    // Brackets inside a string are text, not nesting: this file loads.
    std::string in_string = json;
    in_string.insert(in_string.size() - 1, ",\"extras\":\"" + deep + "\"");
    const fs::path text = temp_dir() / "brackets_in_string.gltf";
    write_file(text, in_string);
    EXPECT_EQ(load_error(text.string()), "");
}

// Buffer URIs resolve inside the scene's folder only: a sub-folder file loads; "../", an
// absolute path and a FIFO (which blocked forever) are refused with the URI's name, and the
// message says nothing of the outside file's size.
TEST(GltfLoader, ExternalFilesStayInTheScenesFolder) {
    const Gltf g = quad_gltf();
    const fs::path dir = temp_dir() / "confined";
    fs::create_directories(dir / "data");
    const std::string bytes(g.bin.begin(), g.bin.end());
    write_file(dir / "data" / "quad.bin", bytes);
    write_file(temp_dir() / "outside.bin", bytes + std::string(4321, 'x'));
    auto with_uri = [&](const std::string& name, const std::string& uri) {
        json d = g.finished();
        d["buffers"][0]["uri"] = uri;
        write_file(dir / name, d.dump());
        return (dir / name).string();
    };
    EXPECT_EQ(load_error(with_uri("inside.gltf", "data/quad.bin")), "");
    const std::string up = load_error(with_uri("up.gltf", "../outside.bin"));
    EXPECT_NE(up.find("outside.bin' refused: outside the scene's folder"), std::string::npos) << up;
    EXPECT_EQ(up.find("4321"), std::string::npos) << up;
    EXPECT_EQ(up.find(std::to_string(bytes.size() + 4321)), std::string::npos) << up;
    const std::string abs = load_error(with_uri("abs.gltf", (temp_dir() / "outside.bin").string()));
    EXPECT_NE(abs.find("refused"), std::string::npos) << abs;
    ASSERT_EQ(mkfifo((dir / "pipe.bin").c_str(), 0600), 0);
    const std::string fifo = load_error(with_uri("fifo.gltf", "pipe.bin"));
    EXPECT_NE(fifo.find("not a regular file"), std::string::npos) << fifo;
}

// An accessor without a bufferView and a count near the old cap (2^28) made the loader
// allocate gigabytes before anything refused the file: now refused by its count, at once.
TEST(GltfLoader, HugeAccessorWithoutDataIsRefused) {
    json d = quad_gltf().finished();
    for (json& a : d["accessors"]) {
        if (a["type"] != "VEC3") continue;
        a.erase("bufferView");
        a.erase("byteOffset");
        a["count"] = 250000000;
    }
    const fs::path path = temp_dir() / "huge_accessor.gltf";
    write_file(path, d.dump());
    const std::string e = load_error(path.string());
    EXPECT_NE(e.find("accessor count 250000000 without a bufferView (at most 16777216)"),
              std::string::npos)
        << e;
}

// A non-finite position is reported as the file has it: the file, the accessor, the element
// and the value before any node transform.
TEST(GltfLoader, NonFinitePositionNamesFileAndElement) {
    Gltf g = quad_gltf();
    const float nan = std::nanf("");
    std::memcpy(g.bin.data() + 12 * 2 + 4, &nan, 4);  // element 2, y
    const std::string e = load_error(g.write("nan_position.gltf"));
    EXPECT_NE(e.find("nan_position.gltf"), std::string::npos) << e;
    EXPECT_NE(e.find("non-finite position at element 2 = ("), std::string::npos) << e;
}

TEST(GltfLoader, IndexOutOfRange) {
    Gltf g;
    const int pos = g.positions(kQuad);
    const int idx = g.indices(std::vector<uint16_t>{0, 1, 7}, kU16);
    g.root({{"mesh", g.mesh(pos, idx)}});
    const std::string e = load_error(g.write("badindex.gltf"));
    EXPECT_NE(e.find("index 7 out of range"), std::string::npos) << e;
    EXPECT_NE(e.find("badindex.gltf"), std::string::npos) << e;
}

TEST(GltfLoader, AccessorOutOfBounds) {
    Gltf g = quad_gltf();
    g.doc["accessors"][0]["count"] = 40;
    std::string e = load_error(g.write("oob.gltf"));
    EXPECT_NE(e.find("out of bounds"), std::string::npos) << e;

    // Array indices that point nowhere.
    g = quad_gltf();
    g.doc["meshes"][0]["primitives"][0]["attributes"]["POSITION"] = 9;
    EXPECT_NE(load_error(g.write("noacc.gltf")).find("accessor 9 out of range"), std::string::npos);
    g = quad_gltf();
    g.doc["meshes"][0]["primitives"][0]["material"] = 3;
    EXPECT_NE(load_error(g.write("nomat.gltf")).find("material index 3"), std::string::npos);
    g = quad_gltf();
    g.doc["nodes"][0]["children"] = {0};
    EXPECT_NE(load_error(g.write("cycle.gltf")).find("more than once"), std::string::npos);
}

// KHR_mesh_quantization: integer positions (the node's scale undoes them), normalized byte
// normals, normalized short texture coordinates, each read as glTF maps it.
TEST(GltfLoader, QuantizedAttributes) {
    Gltf g;
    const std::vector<uint16_t> p = {0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0};  // VEC3 + pad: stride 8
    const int pos = g.accessor(g.view(p.data(), p.size() * 2, 8), kU16, 3, "VEC3");
    const std::vector<int8_t> n = {0, 0, 127, 0, 0, 0, -128, 0, 127, 0, 0, 0};  // stride 4
    const int nrm = g.accessor(g.view(n.data(), n.size(), 4), 5120, 3, "VEC3");
    g.doc["accessors"][nrm]["normalized"] = true;
    const std::vector<int16_t> t = {32767, 0, -32768, 16384, 0, -32767};
    const int tc = g.accessor(g.view(t.data(), t.size() * 2), 5122, 3, "VEC2");
    g.doc["accessors"][tc]["normalized"] = true;
    const int mesh = g.mesh(pos);
    g.doc["meshes"][mesh]["primitives"][0]["attributes"]["NORMAL"] = nrm;
    g.doc["meshes"][mesh]["primitives"][0]["attributes"]["TEXCOORD_0"] = tc;
    g.doc["extensionsUsed"] = {"KHR_mesh_quantization"};
    g.doc["extensionsRequired"] = {"KHR_mesh_quantization"};
    g.root({{"mesh", mesh}, {"scale", {0.5, 0.25, 1}}});
    Scene s = load_gltf(g.write("quantized.gltf"));
    ASSERT_EQ(s.triangles.size(), 1u);
    expect_vec(s.triangles[0].v1, {0.5f, 0, 0});
    expect_vec(s.triangles[0].v2, {0, 0.25f, 0});
    ASSERT_EQ(s.attributes.size(), 1u);
    expect_vec(s.attributes[0].n[0], {0, 0, 1});
    expect_vec(s.attributes[0].n[1], {0, 0, -1});  // -128 clamps to -1
    expect_vec(s.attributes[0].n[2], {1, 0, 0});
    EXPECT_FLOAT_EQ(s.attributes[0].uv[0].x, 1.f);
    EXPECT_FLOAT_EQ(s.attributes[0].uv[1].x, -1.f);  // -32768 clamps to -1
    EXPECT_FLOAT_EQ(s.attributes[0].uv[1].y, 16384.f / 32767.f);
    EXPECT_FLOAT_EQ(s.attributes[0].uv[2].y, -1.f);
    EXPECT_EQ(s.extensions, std::vector<std::string>{"KHR_mesh_quantization"});
    // Unnormalized normals and 32-bit integer positions are not glTF's.
    g.doc["accessors"][nrm]["normalized"] = false;
    std::string e = load_error(g.write("int_normals.gltf"));
    EXPECT_NE(e.find("NORMAL must be VEC3 of float or"), std::string::npos) << e;
    g.doc["accessors"][nrm]["normalized"] = true;
    g.doc["accessors"][pos]["componentType"] = kU32;
    e = load_error(g.write("u32_positions.gltf"));
    EXPECT_NE(e.find("POSITION must be VEC3 of float or"), std::string::npos) << e;
}

TEST(GltfLoader, UnsupportedRequiredExtension) {
    Gltf g = quad_gltf();
    g.doc["extensionsUsed"] = {"KHR_materials_iridescence"};
    g.doc["extensionsRequired"] = {"KHR_materials_iridescence"};
    std::string e = load_error(g.write("iridescence.gltf"));
    EXPECT_NE(e.find("KHR_materials_iridescence"), std::string::npos) << e;
    EXPECT_NE(e.find("requires unsupported"), std::string::npos) << e;
    // KTX2 textures: named, with what to do instead.
    g.doc["extensionsUsed"] = {"KHR_texture_basisu"};
    g.doc["extensionsRequired"] = {"KHR_texture_basisu"};
    e = load_error(g.write("basisu.gltf"));
    EXPECT_NE(e.find("KHR_texture_basisu (KTX2 textures"), std::string::npos) << e;
    EXPECT_NE(e.find("gltfpack without -tc"), std::string::npos) << e;
    // A supported extension may be required.
    g.doc["extensionsRequired"] = {"KHR_materials_ior"};
    EXPECT_EQ(load_error(g.write("ior_required.gltf")), "");
}

// A quad with texture coordinates (0,0) (1,0) (1,1) (0,1) at its corners and a 2x1 PNG texture
// on each of the material's slots given.
Gltf textured_quad(const std::vector<const char*>& slots) {
    Gltf g = quad_gltf();
    const std::vector<float> uv = {0, 0, 1, 0, 1, 1, 0, 1};
    const int tc = g.accessor(g.view(uv.data(), uv.size() * 4), kFloat, 4, "VEC2");
    g.doc["meshes"][0]["primitives"][0]["attributes"]["TEXCOORD_0"] = tc;
    const std::vector<unsigned char> png = encode_png8(2, 1, {255, 0, 0, 0, 0, 255});
    g.doc["images"] = {{{"uri", "data:image/png;base64," + base64(png)}}};
    g.doc["textures"] = {{{"source", 0}}};
    json& m = g.doc["materials"][0];
    for (const char* slot : slots) {
        if (std::string(slot) == "baseColorTexture")
            m["pbrMetallicRoughness"][slot] = {{"index", 0}};
        else
            m[slot] = {{"index", 0}};
    }
    return g;
}

// KHR_texture_transform: offset, rotation and scale baked into the texture coordinates as
// glTF's T * R * S (the values worked by hand from the extension's definition: rotation
// counter-clockwise by pi/2 takes (u, v) to (v, -u)).
TEST(GltfLoader, TextureTransformIsBakedIntoTextureCoordinates) {
    Gltf g = textured_quad({"baseColorTexture", "emissiveTexture"});
    const json transform = {
        {"offset", {0.5, 0.25}}, {"rotation", 1.5707963267948966}, {"scale", {2, 3}}};
    json& m = g.doc["materials"][0];
    m["pbrMetallicRoughness"]["baseColorTexture"]["extensions"]["KHR_texture_transform"] =
        transform;
    m["emissiveTexture"]["extensions"]["KHR_texture_transform"] = transform;
    g.doc["extensionsUsed"] = {"KHR_texture_transform"};
    g.doc["extensionsRequired"] = {"KHR_texture_transform"};
    Scene s = load_gltf(g.write("uv_transform.gltf"));
    ASSERT_EQ(s.attributes.size(), 2u);
    // Triangle 0 has corners 0, 1, 2: (0,0) -> (0.5, 0.25); (1,0) -> S (2,0), R (0,-2),
    // T (0.5,-1.75); (1,1) -> S (2,3), R (3,-2), T (3.5,-1.75). Triangle 1 ends at (0,1) ->
    // S (0,3), R (3,0), T (3.5,0.25).
    const auto near = [](glm::vec2 got, glm::vec2 want) {
        EXPECT_NEAR(got.x, want.x, 1e-6f);
        EXPECT_NEAR(got.y, want.y, 1e-6f);
    };
    near(s.attributes[0].uv[0], {0.5f, 0.25f});
    near(s.attributes[0].uv[1], {0.5f, -1.75f});
    near(s.attributes[0].uv[2], {3.5f, -1.75f});
    near(s.attributes[1].uv[2], {3.5f, 0.25f});
    EXPECT_TRUE(s.warnings.empty()) << ::testing::PrintToString(s.warnings);
    // Slots that disagree: the base color's transform is used, with a warning.
    m["emissiveTexture"]["extensions"]["KHR_texture_transform"]["rotation"] = 0;
    s = load_gltf(g.write("uv_transform_differs.gltf"));
    near(s.attributes[0].uv[1], {0.5f, -1.75f});
    EXPECT_TRUE(has_warning(s, "differ; baseColorTexture's is applied"))
        << ::testing::PrintToString(s.warnings);
    // A texCoord other than 0 in the transform leaves the texture out, warned.
    m["emissiveTexture"]["extensions"]["KHR_texture_transform"]["texCoord"] = 1;
    s = load_gltf(g.write("uv_transform_texcoord.gltf"));
    EXPECT_LT(s.materials[0].tex_emission, 0);
    EXPECT_GE(s.materials[0].tex_base, 0);
    EXPECT_TRUE(has_warning(s, "texture coordinates 0")) << ::testing::PrintToString(s.warnings);
    // Malformed members are errors naming the slot.
    m["emissiveTexture"]["extensions"]["KHR_texture_transform"] = {{"scale", {1, "x"}}};
    const std::string e = load_error(g.write("uv_transform_bad.gltf"));
    EXPECT_NE(e.find("emissiveTexture KHR_texture_transform: 'scale' must be two numbers"),
              std::string::npos)
        << e;
}

// KHR_materials_volume: Beer-Lambert absorption -ln(attenuationColor) / attenuationDistance
// inside glass that is not thin-walled; thin-walled or opaque materials absorb nothing.
TEST(GltfLoader, VolumeAbsorption) {
    Gltf g = quad_gltf();
    json& m = g.doc["materials"][0];
    m["extensions"]["KHR_materials_transmission"] = {{"transmissionFactor", 1}};
    m["extensions"]["KHR_materials_volume"] = {{"thicknessFactor", 1},
                                               {"attenuationDistance", 2},
                                               {"attenuationColor", {0.5, 0.25, 1}}};
    g.doc["extensionsUsed"] = {"KHR_materials_transmission", "KHR_materials_volume"};
    Scene s = load_gltf(g.write("volume.gltf"));
    expect_vec(s.materials[0].absorption, {std::log(2.f) / 2, std::log(4.f) / 2, 0});
    EXPECT_TRUE(s.warnings.empty()) << ::testing::PrintToString(s.warnings);
    // Thin-walled (thickness 0): clear.
    m["extensions"]["KHR_materials_volume"]["thicknessFactor"] = 0;
    expect_vec(load_gltf(g.write("thin.gltf")).materials[0].absorption, {0, 0, 0});
    // Without transmission: ignored, warned.
    m["extensions"]["KHR_materials_volume"]["thicknessFactor"] = 1;
    m["extensions"].erase("KHR_materials_transmission");
    s = load_gltf(g.write("opaque_volume.gltf"));
    expect_vec(s.materials[0].absorption, {0, 0, 0});
    EXPECT_TRUE(has_warning(s, "without KHR_materials_transmission"));
    // A colour outside [0, 1] or a distance of 0: errors.
    m["extensions"]["KHR_materials_transmission"] = {{"transmissionFactor", 1}};
    m["extensions"]["KHR_materials_volume"]["attenuationColor"] = {0.5, 2, 1};
    std::string e = load_error(g.write("bad_color.gltf"));
    EXPECT_NE(e.find("attenuationColor must be in [0, 1]"), std::string::npos) << e;
    m["extensions"]["KHR_materials_volume"]["attenuationColor"] = {0.5, 0.5, 1};
    m["extensions"]["KHR_materials_volume"]["attenuationDistance"] = 0;
    e = load_error(g.write("bad_distance.gltf"));
    EXPECT_NE(e.find("attenuationDistance > 0"), std::string::npos) << e;
}

// KHR_materials_clearcoat and KHR_materials_sheen: factors, textures, and the material they
// make (metallic-roughness with layers, even where it would have been a mirror).
TEST(GltfLoader, ClearcoatAndSheen) {
    Gltf g = quad_gltf();
    json& m = g.doc["materials"][0];
    m["pbrMetallicRoughness"] = {{"metallicFactor", 1}, {"roughnessFactor", 0}};
    g.doc["images"] = {
        {{"uri", "data:image/png;base64," + base64(encode_png8(2, 1, {255, 0, 0, 0, 0, 255}))}}};
    g.doc["textures"] = {{{"source", 0}}};
    m["extensions"]["KHR_materials_clearcoat"] = {{"clearcoatFactor", 0.5},
                                                  {"clearcoatRoughnessFactor", 0.25},
                                                  {"clearcoatRoughnessTexture", {{"index", 0}}},
                                                  {"clearcoatNormalTexture", {{"index", 0}}}};
    m["extensions"]["KHR_materials_sheen"] = {{"sheenColorFactor", {1, 0.5, 0.25}},
                                              {"sheenRoughnessFactor", 0.75}};
    g.doc["extensionsUsed"] = {"KHR_materials_clearcoat", "KHR_materials_sheen"};
    Scene s = load_gltf(g.write("layers.gltf"));
    const Material& l = s.materials[0];
    EXPECT_EQ(l.type, MaterialType::Pbr);
    EXPECT_FLOAT_EQ(l.clearcoat, 0.5f);
    EXPECT_FLOAT_EQ(l.clearcoat_roughness, 0.25f);
    EXPECT_EQ(l.tex_clearcoat, -1);
    EXPECT_GE(l.tex_clearcoat_roughness, 0);
    expect_vec(l.sheen_color, {1, 0.5, 0.25});
    EXPECT_FLOAT_EQ(l.sheen_roughness, 0.75f);
    EXPECT_TRUE(has_warning(s, "clearcoatNormalTexture is not used"))
        << ::testing::PrintToString(s.warnings);
    // Without layers the same factors make the mirror.
    m.erase("extensions");
    EXPECT_EQ(load_gltf(g.write("mirror.gltf")).materials[0].type, MaterialType::Mirror);
    // Factors outside [0, 1] and a texture without an index: errors naming the material.
    m["extensions"]["KHR_materials_clearcoat"] = {{"clearcoatFactor", 1.5}};
    std::string e = load_error(g.write("bad_coat.gltf"));
    EXPECT_NE(e.find("KHR_materials_clearcoat: 'clearcoatFactor' must be a number in [0, 1]"),
              std::string::npos)
        << e;
    m["extensions"]["KHR_materials_clearcoat"] = {{"clearcoatFactor", 1},
                                                  {"clearcoatTexture", {{"texCoord", 0}}}};
    e = load_error(g.write("bad_coat_texture.gltf"));
    EXPECT_NE(e.find("'clearcoatTexture' must be an object with an index"), std::string::npos) << e;
    m["extensions"].erase("KHR_materials_clearcoat");
    m["extensions"]["KHR_materials_sheen"] = {{"sheenColorFactor", {1, -0.5, 0}}};
    e = load_error(g.write("bad_sheen.gltf"));
    EXPECT_NE(e.find("'sheenColorFactor' must be three numbers in [0, 1]"), std::string::npos) << e;
}

// Hand-checked files shipped with the tests.
TEST(GltfLoader, DataFiles) {
    const std::string dir = MCPT_TEST_DATA_DIR;
    Scene s = load_gltf(dir + "/emissive_triangle.gltf");
    ASSERT_EQ(s.triangles.size(), 1u);
    expect_vec(s.triangles[0].v0, {0, 0, -2});
    expect_vec(s.triangles[0].v1, {1, 0, -2});
    expect_vec(s.triangles[0].v2, {0, 1, -2});
    ASSERT_TRUE(s.has_camera);
    expect_vec(s.camera.position, {0, 0, 3});
    EXPECT_FLOAT_EQ(s.camera.yfov, 0.8f);
    expect_vec(s.materials[0].emission, {2, 2, 2});
    EXPECT_EQ(validate_scene(s).degenerate_dropped, 0u);

    // Draco required, no primitive compressed: loads where the build has the decoder.
    const std::string e = load_error(dir + "/requires_draco.gltf");
    if (GltfCompression::has_draco())
        EXPECT_EQ(e, "");
    else
        EXPECT_NE(e.find("KHR_draco_mesh_compression (this build has no Draco"), std::string::npos)
            << e;
}

// KHR_lights_punctual (tests/data/lamps.gltf, made by hand): a point light on a child of a
// node scaled by 2, a spot turned -90 degrees about X, a sun turned -60 degrees; glTF's
// candela and lux to W/sr and W/m^2 at 683 lm/W.
TEST(GltfLoader, PunctualLights) {
    const Scene s = load_gltf(std::string(MCPT_TEST_DATA_DIR) + "/lamps.gltf");
    ASSERT_EQ(s.punctual_lights.size(), 3u);
    EXPECT_TRUE(s.warnings.empty()) << ::testing::PrintToString(s.warnings);
    // In node order, depth first: the point light's parent comes before the spot.
    const PunctualLight &point = s.punctual_lights[0], &spot = s.punctual_lights[1],
                        &sun = s.punctual_lights[2];
    EXPECT_EQ(point.kind, PunctualKind::Point);
    expect_vec(point.position, {1, 2, 1});
    expect_vec(point.intensity, {2000.f / 683, 0.9f * 2000 / 683, 0.8f * 2000 / 683});
    EXPECT_EQ(spot.kind, PunctualKind::Spot);
    expect_vec(spot.position, {-1, 2.5f, 1});
    expect_vec(spot.direction, {0, -1, 0});
    EXPECT_FLOAT_EQ(spot.inner_cone, 0.3f);
    EXPECT_FLOAT_EQ(spot.outer_cone, 0.5f);
    EXPECT_EQ(sun.kind, PunctualKind::Directional);
    expect_vec(sun.direction, {0, -std::sin(float(M_PI) / 3), -0.5f});
    expect_vec(sun.intensity, {1.5f, 1.5f, 1.5f});
}

// Bad lamps are errors naming the light.
TEST(GltfLoader, BadPunctualLights) {
    const auto with_light = [](json light) {
        Gltf g = quad_gltf();
        g.doc["extensionsUsed"] = {"KHR_lights_punctual"};
        g.doc["extensions"]["KHR_lights_punctual"]["lights"] = json::array({light});
        g.doc["nodes"].push_back({{"extensions", {{"KHR_lights_punctual", {{"light", 0}}}}}});
        g.doc["scenes"][0]["nodes"].push_back(g.doc["nodes"].size() - 1);
        return load_error(g.write("bad_light.gltf"));
    };
    EXPECT_NE(with_light({{"type", "area"}}).find("unknown type 'area'"), std::string::npos);
    EXPECT_NE(with_light({{"type", "point"}, {"intensity", -1}}).find(">= 0"), std::string::npos);
    EXPECT_NE(with_light({{"name", "s"},
                          {"type", "spot"},
                          {"spot", {{"innerConeAngle", 0.6}, {"outerConeAngle", 0.5}}}})
                  .find("light 's': spot cone angles"),
              std::string::npos);
    // Finite in double, beyond float once in W/sr (1e42 / 683): named, not left to become Inf.
    EXPECT_NE(with_light({{"type", "point"}, {"intensity", 1e42}}).find("overflows single"),
              std::string::npos);
    EXPECT_EQ(with_light({{"type", "point"}, {"intensity", 10}}), "");
}

}  // namespace
}  // namespace mcpt
