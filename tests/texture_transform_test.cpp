// KHR_texture_transform on both APIs, placed texel for texel: a quad whose emissive 2x2
// texture (four colours, nearest, clamped) is turned a quarter turn and shifted by its
// transform renders, at the same seed, the image of the same quad with the texels turned on
// the host and no transform. Control: the quarter turn the other way (a sign error in the
// rotation) changes most pixels.
#include <gtest/gtest.h>

#include <cmath>

#include "common/io/image_io.h"
#include "light_cases.h"
#include "test_util.h"
#include "tests/gltf_builder.h"

namespace mcpt {
namespace {

using namespace gltf_test;

using Rgb = std::array<unsigned char, 3>;
const Rgb kRed = {255, 0, 0}, kGreen = {0, 255, 0}, kBlue = {0, 0, 255}, kWhite = {255, 255, 255};

// The unit quad (texture coordinates (0,0) (1,0) (1,1) (0,1) at its corners) emitting the 2x2
// texture of rows {t00, t01} and {t10, t11}, under `transform` (none when null).
Scene emissive_texture_quad(const std::array<Rgb, 4>& texels, const json& transform,
                            const std::string& name) {
    Gltf g = quad_gltf();
    const std::vector<float> uv = {0, 0, 1, 0, 1, 1, 0, 1};
    const int tc = g.accessor(g.view(uv.data(), uv.size() * 4), kFloat, 4, "VEC2");
    g.doc["meshes"][0]["primitives"][0]["attributes"]["TEXCOORD_0"] = tc;
    std::vector<uint8_t> rgb;
    for (const Rgb& t : texels) rgb.insert(rgb.end(), t.begin(), t.end());
    g.doc["images"] = {{{"uri", "data:image/png;base64," + base64(encode_png8(2, 2, rgb))}}};
    g.doc["samplers"] = {{{"magFilter", 9728}, {"wrapS", 33071}, {"wrapT", 33071}}};
    g.doc["textures"] = {{{"source", 0}, {"sampler", 0}}};
    json slot = {{"index", 0}};
    if (!transform.is_null()) {
        slot["extensions"] = {{"KHR_texture_transform", transform}};
        g.doc["extensionsUsed"] = {"KHR_texture_transform"};
    }
    g.doc["materials"][0]["emissiveTexture"] = slot;
    return load_gltf(g.write(name));
}

// Pixels whose mean differs by more than 0.1% of the brightest channel.
int pixels_apart(const RenderResult& a, const RenderResult& b) {
    const std::vector<float> ia = a.mean_image(), ib = b.mean_image();
    int apart = 0;
    for (size_t i = 0; i < ia.size(); i += 3)
        for (int c = 0; c < 3; ++c)
            if (std::abs(ia[i + c] - ib[i + c]) > 1e-3f) {
                ++apart;
                break;
            }
    return apart;
}

class TextureTransform : public ::testing::TestWithParam<std::string> {};

TEST_P(TextureTransform, QuarterTurnPlacesTexelsAsTurnedOnTheHost) {
    const std::string api = GetParam();
    // The transform takes (u, v) to (v, 1 - u): texel (column x, row y) of the turned texture
    // is the original's (column y, row 1 - x).
    const std::array<Rgb, 4> texture = {kRed, kGreen, kBlue, kWhite};
    const std::array<Rgb, 4> turned = {kBlue, kRed, kWhite, kGreen};
    const double quarter = 1.5707963267948966;
    const Scene host = emissive_texture_quad(turned, nullptr, "turned_on_host.gltf");
    const Scene device = emissive_texture_quad(texture, {{"rotation", quarter}, {"offset", {0, 1}}},
                                               "turned_by_transform.gltf");
    const Scene control = emissive_texture_quad(
        texture, {{"rotation", -quarter}, {"offset", {1, 0}}}, "turned_the_other_way.gltf");
    constexpr int kSize = 16;
    test::CaseRender how;
    how.spp = 4;
    const RenderResult a = test::render_case(api, host, kSize, how);
    const RenderResult b = test::render_case(api, device, kSize, how);
    const RenderResult c = test::render_case(api, control, kSize, how);
    // The quad fills much of the frame, in four colours.
    EXPECT_GT(a.mean_radiance(), 0.1);
    // The same image but where a sample lands within rounding of a texel boundary.
    EXPECT_LE(pixels_apart(a, b), 2) << api;
    EXPECT_GT(pixels_apart(a, c), kSize * kSize / 4) << api;
}

INSTANTIATE_TEST_SUITE_P(Apis, TextureTransform, ::testing::ValuesIn(test::test_apis()));

}  // namespace
}  // namespace mcpt
