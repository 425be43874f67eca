// The environment map's orientation and --env-rotate's sign, against Blender's convention
// (Cycles' equirectangular mapping, u = 1/2 - atan2(y, x) / 2 pi in Blender's axes, and a
// Mapping node turning the lookup direction about Blender's Z), through the glTF exporter's
// axes (Blender's x, -y, z are glTF's X, Z, Y). The map is a Radiance file written here byte
// by byte (flat RGBE), whose texels differ left to right and top to bottom, so that nothing
// of the project's own writer or reader stands between the file and the check.
#include <gtest/gtest.h>

#include <cmath>

#include "common/accel/kdtree.h"
#include "common/gpu/lights.h"
#include "common/render/gpu_scene.h"
#include "common/scene/environment.h"
#include "light_cases.h"
#include "test_util.h"

namespace mcpt {
namespace {

using test::kPi;

// A flat RGBE .hdr of w x h texels (w < 8: stb reads it flat), texel (x, y) = rgb(x, y),
// each channel a small integer (exact in RGBE).
template <class Rgb>
std::vector<unsigned char> radiance_file(int w, int h, Rgb rgb) {
    const std::string head = "#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y " + std::to_string(h) +
                             " +X " + std::to_string(w) + "\n";
    std::vector<unsigned char> out(head.begin(), head.end());
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            const glm::vec3 c = rgb(x, y);
            const float m = std::max(c.x, std::max(c.y, c.z));
            int e = 0;
            const float scale = std::frexp(m, &e) * 256.f / m;
            out.push_back((unsigned char)(c.x * scale));
            out.push_back((unsigned char)(c.y * scale));
            out.push_back((unsigned char)(c.z * scale));
            out.push_back((unsigned char)(e + 128));
        }
    return out;
}

// The glTF direction Blender shows the centre of texel (x, y) of a w x h map in, under a
// Mapping node rotation of `deg` about Z (Cycles: u = 1/2 - atan2(y, x) / 2 pi, v = 1 -
// acos(z) / pi with v = 1 up, of the lookup direction R(deg) d; row 0 the file's first, top).
glm::dvec3 blender_direction(int x, int y, int w, int h, double deg) {
    const double u = (x + 0.5) / w, v_up = 1 - (y + 0.5) / h;
    const double phi = 2 * kPi * (0.5 - u), theta = kPi * (1 - v_up);
    const glm::dvec3 lookup(std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi),
                            std::cos(theta));
    const double a = -deg * kPi / 180;  // R(deg) d = lookup: d = R(-deg) lookup
    const glm::dvec3 b(std::cos(a) * lookup.x - std::sin(a) * lookup.y,
                       std::sin(a) * lookup.x + std::cos(a) * lookup.y, lookup.z);
    return {b.x, b.z, -b.y};  // Blender's (x, y, z) is glTF's (X, -Z, Y)
}

// Every texel of the file, looked up in the direction Blender shows its centre in, at four
// rotations.
TEST(EnvironmentOrientation, TexelsWhereBlenderPutsThem) {
    constexpr int kW = 7, kH = 4;
    const std::vector<unsigned char> file =
        radiance_file(kW, kH, [](int x, int y) { return glm::vec3(x + 1, y + 1, 1); });
    Scene scene = test::plane_scene(0.5f, 1.f, 1.f);
    scene.environment = load_environment_memory(file.data(), file.size(), "hand-written.hdr");
    for (double deg : {0.0, 90.0, -30.0, 200.0}) {
        scene.environment.rotate_deg = float(deg);
        const GpuScene g = pack_scene(scene, build_kdtree(scene.triangles, TreeOptions{}));
        for (int y = 0; y < kH; ++y)
            for (int x = 0; x < kW; ++x) {
                const glm::dvec3 d = blender_direction(x, y, kW, kH, deg);
                const glm::vec4 t = gpu::env_lookup(&g.params, nullptr, nullptr, nullptr, nullptr,
                                                    nullptr, nullptr, nullptr, nullptr,
                                                    g.texels.data(), glm::vec3(d));
                ASSERT_NEAR(t.x, float(x + 1), 1e-3f * (x + 1))
                    << "column of texel " << x << ", " << y << " at rotation " << deg;
                ASSERT_NEAR(t.y, float(y + 1), 1e-3f * (y + 1))
                    << "row of texel " << x << ", " << y << " at rotation " << deg;
            }
    }
}

// A Lambertian sphere seen from above (image right = +X, image bottom = +Z) under a map bright
// only in u in [1/2, 3/4) (Blender: from +X toward -Y, glTF's +X toward +Z): the bright
// quarter of the image is the bottom right; turned by 90 (a Mapping node's Z rotation of 90
// in Blender), the bottom left.
class EnvironmentOrientationRender : public ::testing::TestWithParam<std::string> {};

TEST_P(EnvironmentOrientationRender, BrightSideWhereBlenderPutsIt) {
    constexpr int kW = 8, kH = 4, kSize = 32;
    const std::vector<unsigned char> file = radiance_file(kW, kH, [](int x, int) {
        return x == 4 || x == 5 ? glm::vec3(8, 8, 8) : glm::vec3(0.125f, 0.125f, 0.125f);
    });
    Scene scene;
    Material m;
    m.color = glm::vec3(0.8f);
    scene.add_material(m);
    scene.spheres.push_back({glm::vec3(0.f), 1.f, 0});
    scene.camera.position = glm::vec3(0, 4, 0);
    scene.camera.forward = glm::vec3(0, -1, 0);
    scene.camera.up = glm::vec3(0, 0, -1);
    scene.camera.yfov = 0.55f;
    scene.has_camera = true;
    scene.environment = load_environment_memory(file.data(), file.size(), "hand-written.hdr");
    for (const auto& [deg, bright_right] : {std::pair{0.f, true}, std::pair{90.f, false}}) {
        scene.environment.rotate_deg = deg;
        test::CaseRender how;
        how.spp = 64;
        const RenderResult r = test::render_case(GetParam(), scene, kSize, how);
        double q[2][2] = {{0, 0}, {0, 0}};  // [bottom][right]
        for (int y = 0; y < kSize; ++y)
            for (int x = 0; x < kSize; ++x)
                q[y >= kSize / 2][x >= kSize / 2] +=
                    r.sum[3 * size_t(y * kSize + x)] / double(r.spp);
        const double bright = q[1][bright_right];
        std::printf("%s, rotation %g: quarters top %.1f %.1f, bottom %.1f %.1f\n",
                    GetParam().c_str(), deg, q[0][0], q[0][1], q[1][0], q[1][1]);
        for (int b = 0; b < 2; ++b) {
            for (int rt = 0; rt < 2; ++rt) {
                if (b == 1 && rt == int(bright_right)) continue;
                EXPECT_GT(bright, 2 * q[b][rt])
                    << GetParam() << ", rotation " << deg << ": bright quarter not at the "
                    << (bright_right ? "bottom right" : "bottom left");
            }
        }
    }
}

// The map seen directly (camera rays): bilinear between texel centres, exact per pixel against
// the test's own bilinear formula over each pixel's directions; per texel (nearest) rejected.
// Three views: an oblique one, one toward -X (u wraps from 1 to 0 across the image: texel
// columns 7 and 0 are blended) and one toward the zenith (v clamps at the pole). The texels
// repeat every 11 columns, so no two columns are alike (a period of 7 made columns 7 and 0
// equal, and u clamped at the seam passed).
TEST_P(EnvironmentOrientationRender, MapSeenDirectlyIsBilinear) {
    constexpr int kW = 8, kH = 4, kSize = 24;
    const std::vector<unsigned char> file = radiance_file(
        kW, kH, [](int x, int y) { return glm::vec3(float(1 + ((x * 5 + y * 3) % 11)), 1, 1); });
    Scene scene;
    Material m;
    scene.add_material(m);
    scene.spheres.push_back({glm::vec3(0, -100, 0), 0.01f, 0});  // out of view: not a light
    scene.camera.position = glm::vec3(0.f);
    scene.camera.yfov = 1.2f;
    scene.has_camera = true;
    scene.environment = load_environment_memory(file.data(), file.size(), "hand-written.hdr");
    for (const auto& [view, forward] :
         {std::pair{"oblique", glm::vec3(1, 0.3f, 0.5f)},
          std::pair{"toward -X", glm::vec3(-1, 0.1f, 0.2f)},
          std::pair{"toward the zenith", glm::vec3(0.05f, 1, 0.1f)}}) {
        scene.camera.forward = glm::normalize(forward);
        const glm::vec3 helper =
            std::abs(scene.camera.forward.y) > 0.9f ? glm::vec3(0, 0, 1) : glm::vec3(0, 1, 0);
        const glm::vec3 right = glm::normalize(glm::cross(scene.camera.forward, helper));
        scene.camera.up = glm::cross(right, scene.camera.forward);
        test::CaseRender how;
        how.spp = 64;
        const RenderResult r = test::render_case(GetParam(), scene, kSize, how);
        // Expected per pixel: the pixel's directions (16 x 16), each to (u, v) by Blender's
        // mapping (the orientation test above), bilinear by the test's own formula.
        const Camera& c = scene.camera;
        const glm::dvec3 w = glm::normalize(glm::dvec3(c.forward));
        const glm::dvec3 u_axis = glm::normalize(glm::cross(w, glm::dvec3(c.up)));
        const glm::dvec3 v_axis = glm::cross(u_axis, w);
        const double t = std::tan(0.5 * double(c.yfov));
        const auto expected = [&](bool nearest) {
            std::vector<double> out(kSize * kSize);
            for (int py = 0; py < kSize; ++py)
                for (int px = 0; px < kSize; ++px) {
                    double sum = 0;
                    for (int j = 0; j < 16; ++j)
                        for (int i = 0; i < 16; ++i) {
                            const double fx = (px + (i + 0.5) / 16) / kSize * 2 - 1;
                            const double fy = 1 - (py + (j + 0.5) / 16) / kSize * 2;
                            const glm::dvec3 d =
                                glm::normalize(w + u_axis * (t * fx) + v_axis * (t * fy));
                            const glm::dvec3 b(d.x, -d.z, d.y);  // Blender's axes
                            double u = 0.5 - std::atan2(b.y, b.x) / (2 * kPi);
                            u -= std::floor(u);
                            const double v = std::acos(std::clamp(b.z, -1.0, 1.0)) / kPi;
                            if (nearest) {
                                const int x = std::min(kW - 1, int(u * kW)),
                                          y = std::min(kH - 1, int(v * kH));
                                sum += 1 + ((x * 5 + y * 3) % 11);
                            } else {
                                sum += test::bilinear_radiance(scene.environment, u, v);
                            }
                        }
                    out[size_t(py * kSize + px)] = sum / 256;
                }
            return out;
        };
        const int off = test::pixels_off(r, expected(false));
        const int off_nearest = test::pixels_off(r, expected(true));
        std::printf("%s, %s: the map seen: %d of %d pixels off bilinear, %d off nearest\n",
                    GetParam().c_str(), view, off, kSize * kSize, off_nearest);
        EXPECT_EQ(off, 0) << view;
        EXPECT_GT(off_nearest, kSize * kSize / 4) << view << ": the control (per texel) passed";
    }
}

INSTANTIATE_TEST_SUITE_P(Api, EnvironmentOrientationRender,
                         ::testing::ValuesIn(test::test_apis()),
                         [](const auto& info) { return info.param; });

}  // namespace
}  // namespace mcpt
