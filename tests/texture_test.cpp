// Texture fetches and per-vertex data (common/gpu/texture.h) as the C++ build of the device
// code: half floats, octahedral normals, wrap modes, bilinear filtering, sRGB decoding, and
// the textured test scene as the glTF loader reads it.
#include "common/gpu/texture.h"

#include <gtest/gtest.h>

#include <cmath>
#include <glm/gtc/packing.hpp>
#include <random>

#include "common/render/gpu_scene.h"
#include "common/render/scene_features.h"
#include "common/scene/gltf_loader.h"

namespace mcpt {
namespace {

TEST(Texture, HalfDecodingMatchesIeee) {
    // Every finite half, against glm's conversion.
    for (uint32_t h = 0; h < 65536; ++h) {
        if ((h & 0x7c00u) == 0x7c00u) continue;
        const float want = glm::unpackHalf1x16(uint16_t(h));
        EXPECT_EQ(gpu::half_to_float(h), want) << std::hex << h;
    }
}

TEST(Texture, OctahedralNormalsRoundTrip) {
    std::mt19937 rng(3);
    std::normal_distribution<float> g;
    float worst = 0;
    for (int i = 0; i < 100000; ++i) {
        glm::vec3 n(g(rng), g(rng), g(rng));
        if (i < 6) n = glm::vec3(0.f), n[i % 3] = i < 3 ? 1.f : -1.f;  // the axes
        n = glm::normalize(n);
        const glm::vec3 back = gpu::normal_from_oct(oct_encode(n));
        worst = std::max(worst, glm::length(glm::cross(n, back)));  // sin of the angle
    }
    EXPECT_LT(worst, 1e-4f) << "radians";
}

TEST(Texture, WrapModes) {
    using gpu::wrap_texel;
    // Repeat, clamp and mirror of a 4-texel axis, including negative coordinates.
    const int i[] = {-5, -1, 0, 3, 4, 7, 8};
    const uint32_t repeat[] = {3, 3, 0, 3, 0, 3, 0};
    const uint32_t clamp[] = {0, 0, 0, 3, 3, 3, 3};
    const uint32_t mirror[] = {3, 0, 0, 3, 3, 0, 0};
    for (int k = 0; k < 7; ++k) {
        EXPECT_EQ(wrap_texel(i[k], 4, TEXTURE_WRAP_REPEAT), repeat[k]) << i[k];
        EXPECT_EQ(wrap_texel(i[k], 4, TEXTURE_WRAP_CLAMP), clamp[k]) << i[k];
        EXPECT_EQ(wrap_texel(i[k], 4, TEXTURE_WRAP_MIRROR), mirror[k]) << i[k];
    }
    EXPECT_EQ(wrap_texel(-16777216, 3, TEXTURE_WRAP_REPEAT), uint32_t((3 - 16777216 % 3) % 3));
    // The bilinear fetch's pair: the same as two calls, at every mode, size and offset tried.
    for (uint32_t mode : {TEXTURE_WRAP_REPEAT, TEXTURE_WRAP_CLAMP, TEXTURE_WRAP_MIRROR})
        for (uint32_t size : {1u, 2u, 3u, 4u, 7u, 4096u})
            for (int i : {-16777216, -16777215, -9, -8, -5, -4, -1, 0, 1, 2, 3, 4, 6, 7, 8,
                          4095, 4096, 8191, 16777214, 16777215}) {
                const gpu::uvec2 pair = gpu::wrap_texel_pair(i, size, mode);
                EXPECT_EQ(pair.x, wrap_texel(i, size, mode)) << i << " " << size << " " << mode;
                EXPECT_EQ(pair.y, wrap_texel(i + 1, size, mode)) << i << " " << size << " " << mode;
            }
}

// A 2 x 2 texture of a scene (texels 0, 1 / 2, 3 in red), sampled through the device code.
struct TinyTexture {
    GpuScene g;
    explicit TinyTexture(TextureWrap wrap, bool nearest = false) {
        Scene s;
        const unsigned char rgba[] = {0, 0, 0, 255, 85, 0, 0, 255, 170, 0, 0, 255, 255, 0, 0, 255};
        s.textures.push_back(texture_from_rgba8("tiny", 2, 2, rgba, false));
        s.textures[0].wrap_s = s.textures[0].wrap_t = wrap;
        s.textures[0].nearest = nearest;
        Material lamp;
        lamp.emission = glm::vec3(1.f);
        s.add_material(lamp);
        s.triangles.push_back({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, 0});
        g = pack_scene(s, build_kdtree(s.triangles, TreeOptions{}));
    }
    float red(float u, float v) const {
        return gpu::sample_texture(&g.params, g.nodes.data(), g.leaf_indices.data(),
                                   g.triangles.data(), g.spheres.data(), g.materials.data(),
                                   g.lights.data(), g.attributes.data(), g.textures.data(),
                                   g.texels.data(), 0u, glm::vec2(u, v))
            .x;
    }
};

TEST(Texture, BilinearBetweenTexelCenters) {
    const TinyTexture t(TextureWrap::Clamp);
    const float r0 = 0.f, r1 = glm::unpackHalf1x16(glm::packHalf1x16(85.f / 255.f)),
                r2 = glm::unpackHalf1x16(glm::packHalf1x16(170.f / 255.f)), r3 = 1.f;
    // Texel centers are exact; their midpoint is the mean of four.
    EXPECT_FLOAT_EQ(t.red(0.25f, 0.25f), r0);
    EXPECT_FLOAT_EQ(t.red(0.75f, 0.25f), r1);
    EXPECT_FLOAT_EQ(t.red(0.25f, 0.75f), r2);
    EXPECT_FLOAT_EQ(t.red(0.5f, 0.5f), 0.25f * (r0 + r1 + r2 + r3));
    // Clamped beyond the edges; repeated around them.
    EXPECT_FLOAT_EQ(t.red(-3.f, 0.25f), r0);
    const TinyTexture rep(TextureWrap::Repeat);
    EXPECT_FLOAT_EQ(rep.red(0.f, 0.25f), 0.5f * (r0 + r1));  // between texel 1 (left) and 0
    EXPECT_FLOAT_EQ(rep.red(5.25f, 0.25f), r0);
    const TinyTexture nearest(TextureWrap::Repeat, true);
    EXPECT_FLOAT_EQ(nearest.red(0.6f, 0.3f), r1);
}

TEST(Texture, SrgbColorChannelsAreDecoded) {
    const unsigned char rgba[] = {128, 128, 128, 128};
    const Texture lin = texture_from_rgba8("l", 1, 1, rgba, false);
    const Texture srgb = texture_from_rgba8("s", 1, 1, rgba, true);
    EXPECT_NEAR(glm::unpackHalf1x16(lin.rgba[0]), 128.f / 255.f, 1e-3f);
    EXPECT_NEAR(glm::unpackHalf1x16(srgb.rgba[0]), 0.2158605f, 1e-3f);  // sRGB 128 -> linear
    EXPECT_EQ(srgb.rgba[3], lin.rgba[3]);                               // alpha stays linear
}

// The textured scene (scripts/make_textured_glb.py): what the loader takes from it.
TEST(Texture, TexturedSceneLoadsEveryInput) {
    Scene s = load_gltf(std::string(MCPT_TEST_DATA_DIR) + "/textured.glb");
    validate_scene(s);
    EXPECT_EQ(s.textures.size(), 5u);
    EXPECT_TRUE(s.vertex_normals);
    ASSERT_EQ(s.attributes.size(), s.triangles.size());
    int base = 0, metal_rough = 0, normal = 0, emission = 0, masked = 0;
    for (const Material& m : s.materials) {
        base += m.tex_base >= 0, metal_rough += m.tex_metal_rough >= 0;
        normal += m.tex_normal >= 0, emission += m.tex_emission >= 0;
        masked += m.alpha_cutoff > 0.f;
    }
    EXPECT_EQ(base, 2);
    EXPECT_EQ(metal_rough, 1);
    EXPECT_EQ(normal, 1);
    EXPECT_EQ(emission, 1);
    EXPECT_EQ(masked, 1);
    // Samplers: the stripes clamp, the holes are nearest, the glow mirrors.
    bool clamp = false, nearest = false, mirror = false;
    for (const Texture& t : s.textures) {
        clamp = clamp || t.wrap_s == TextureWrap::Clamp;
        nearest = nearest || t.nearest;
        mirror = mirror || t.wrap_t == TextureWrap::Mirror;
    }
    EXPECT_TRUE(clamp && nearest && mirror);
    EXPECT_TRUE(s.warnings.empty()) << ::testing::PrintToString(s.warnings);
    const GpuScene g = pack_scene(s, build_kdtree(s.triangles, TreeOptions{}));
    EXPECT_EQ(feature_names(g.features),
              "triangles, diffuse, triangle lights, k-d tree, microfacet, shading normals, "
              "textures, alpha mask");
}

}  // namespace
}  // namespace mcpt
