// The environment map's orientation and --env-rotate's sign, against Blender's convention
// (Cycles' equirectangular mapping, u = 1/2 - atan2(y, x) / 2 pi in Blender's axes, and a
// Mapping node turning the lookup direction about Blender's Z), through the glTF exporter's
// axes (Blender's x, -y, z are glTF's X, Z, Y). The map is a Radiance file written here byte
// by byte (flat RGBE), whose texels differ left to right and top to bottom, so that nothing
// of the project's own writer or reader stands between the file and the check.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

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

// Blender's texel of glTF direction d under a Mapping node rotation of `deg` about Z:
// (column, row), row 0 the file's first (top).
std::pair<double, double> blender_uv(glm::dvec3 d, double deg, int w, int h) {
    glm::dvec3 b(d.x, -d.z, d.y);  // Blender's axes
    const double a = deg * kPi / 180;
    b = glm::dvec3(std::cos(a) * b.x - std::sin(a) * b.y, std::sin(a) * b.x + std::cos(a) * b.y,
                   b.z);  // the Mapping node turns the lookup direction
    const double u = 0.5 - std::atan2(b.y, b.x) / (2 * kPi);
    const double v_up = 1 - std::acos(std::clamp(b.z, -1.0, 1.0)) / kPi;  // Blender's v: 1 = up
    return {(u - std::floor(u)) * w, (1 - v_up) * h};
}

TEST(EnvironmentOrientation, TexelsWhereBlenderPutsThem) {
    constexpr int kW = 7, kH = 4;  // odd width: no column centred on an axis
    const std::vector<unsigned char> file =
        radiance_file(kW, kH, [](int x, int y) { return glm::vec3(x + 1, y + 1, 1); });
    Scene scene = test::plane_scene(0.5f, 1.f, 1.f);
    scene.environment = load_environment_memory(file.data(), file.size(), "hand-written.hdr");
    std::mt19937 rng(11);
    std::normal_distribution<double> normal;
    for (double deg : {0.0, 90.0, -30.0, 200.0}) {
        scene.environment.rotate_deg = float(deg);
        const GpuScene g = pack_scene(scene, build_kdtree(scene.triangles, TreeOptions{}));
        int checked = 0;
        for (int k = 0; k < 400; ++k) {
            const glm::dvec3 d =
                glm::normalize(glm::dvec3(normal(rng), normal(rng), normal(rng)));
            const auto [col, row] = blender_uv(d, deg, kW, kH);
            // Not within rounding of a texel edge.
            if (std::abs(col - std::round(col)) < 1e-3 || std::abs(row - std::round(row)) < 1e-3)
                continue;
            const glm::vec4 t = gpu::env_lookup(&g.params, nullptr, nullptr, nullptr, nullptr,
                                                nullptr, nullptr, nullptr, nullptr,
                                                g.texels.data(), glm::vec3(d));
            ++checked;
            ASSERT_EQ(t.x, float(int(col) % kW + 1))
                << "column at rotation " << deg << ", direction " << d.x << " " << d.y << " " << d.z;
            ASSERT_EQ(t.y, float(std::min(int(row), kH - 1) + 1))
                << "row at rotation " << deg << ", direction " << d.x << " " << d.y << " " << d.z;
        }
        EXPECT_GT(checked, 350);
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

INSTANTIATE_TEST_SUITE_P(Api, EnvironmentOrientationRender,
                         ::testing::ValuesIn(test::test_apis()),
                         [](const auto& info) { return info.param; });

}  // namespace
}  // namespace mcpt
