// Writes common/gpu/sheen_albedo_table.h: the sheen lobe's directional albedo
// E(cos_o, roughness) = integral of D V cos_i over the hemisphere (common/gpu/layers.h), for
// SHEEN_ALBEDO_COS cosines in [0, 1] by SHEEN_ALBEDO_ROUGHNESS roughnesses in
// [MIN_SHEEN_ROUGHNESS, 1], both spaced evenly in their square roots (as sheen_albedo reads
// them), from the device functions themselves (midpoint rule; the lobe is
// symmetric about the plane of wo). With --check it compares the table this build compiled
// with what it computes, within 10^-5 (the ctest Layers.SheenAlbedoTableIsItsGenerator: the
// printed digits are not the same bit for bit in every build type).
// Usage: mcpt_sheen_albedo_gen > common/gpu/sheen_albedo_table.h
//        mcpt_sheen_albedo_gen --check
#include <cmath>
#include <cstdio>
#include <cstring>

#include "common/gpu/layers.h"

namespace {

constexpr int kCos = 32, kRoughness = 16;
static_assert(kCos == SHEEN_ALBEDO_COS && kRoughness == SHEEN_ALBEDO_ROUGHNESS);

double albedo(float cos_o, float roughness) {
    using namespace mcpt::gpu;
    const vec3 wo(std::sqrt(std::max(0.f, 1.f - cos_o * cos_o)), 0.f, cos_o);
    const int n_theta = 400, n_phi = 200;  // phi over [0, pi], doubled
    const double dt = 0.5 * M_PI / n_theta, dp = M_PI / n_phi;
    double sum = 0;
    for (int i = 0; i < n_theta; ++i) {
        const double theta = (i + 0.5) * dt;
        double ring = 0;
        for (int j = 0; j < n_phi; ++j) {
            const double phi = (j + 0.5) * dp;
            const vec3 wi(float(std::sin(theta) * std::cos(phi)),
                          float(std::sin(theta) * std::sin(phi)), float(std::cos(theta)));
            const vec3 h = glm::normalize(wo + wi);
            ring += double(sheen_lobe(wo, wi, h, roughness)) * wi.z;
        }
        sum += ring * std::sin(theta);
    }
    return 2 * sum * dt * dp;
}

}  // namespace

// The table's nodes: roughness row r, cosine column c.
float node_roughness(int r) {
    const float sr = float(r) / float(kRoughness - 1);
    return MIN_SHEEN_ROUGHNESS + (1.f - MIN_SHEEN_ROUGHNESS) * sr * sr;
}
float node_cos(int c) {
    // (At cos 0 exactly the clamped V makes E jump to about 2: the first column is its
    // limit, taken at cos 1e-4.)
    const float sc = float(c) / float(kCos - 1);
    return c == 0 ? 1e-4f : sc * sc;
}

int check() {
    double worst = 0;
    for (int r = 0; r < kRoughness; ++r)
        for (int c = 0; c < kCos; ++c) {
            const double e = albedo(node_cos(c), node_roughness(r));
            const double t = mcpt::gpu::SHEEN_ALBEDO[r * kCos + c];
            worst = std::max(worst, std::fabs(t - e) / (1e-5 * std::fabs(e) + 1e-9));
        }
    std::printf("sheen albedo table: largest difference %.3g of the tolerance\n", worst);
    return worst <= 1 ? 0 : 1;
}

int main(int argc, char** argv) {
    if (argc == 2 && std::strcmp(argv[1], "--check") == 0) return check();
    std::printf(
        "// The sheen lobe's directional albedo E(cos, roughness) (common/gpu/layers.h): %d\n"
        "// cosines in [0, 1] by %d roughnesses in [MIN_SHEEN_ROUGHNESS, 1], each spaced evenly\n"
        "// in its square root, row by row.\n"
        "// Written by tests/sheen_albedo_gen.cpp; do not edit.\n"
        "#ifndef MCPT_GPU_SHEEN_ALBEDO_TABLE_H\n#define MCPT_GPU_SHEEN_ALBEDO_TABLE_H\n\n"
        "#include \"platform.h\"\n\n#define SHEEN_ALBEDO_COS %du\n#define SHEEN_ALBEDO_ROUGHNESS "
        "%du\n\n"
        "MCPT_NAMESPACE_BEGIN\n\n// (GLSL reads the host's copy of the table: layers.h.)\n#if "
        "!defined(MCPT_GLSL)\n"
        "// clang-format off\nMCPT_TABLE(float, SHEEN_ALBEDO, %d)\n",
        kCos, kRoughness, kCos, kRoughness, kCos * kRoughness);
    for (int r = 0; r < kRoughness; ++r) {
        for (int c = 0; c < kCos; ++c) {
            const bool last = r == kRoughness - 1 && c == kCos - 1;
            std::printf("%s%.6ef%s", c % 8 == 0 ? "    " : "",
                        albedo(node_cos(c), node_roughness(r)),
                        last ? "\n" : (c % 8 == 7 ? ",\n" : ", "));
        }
    }
    std::printf(
        "MCPT_TABLE_END;\n// clang-format on\n#endif\n\nMCPT_NAMESPACE_END\n\n"
        "#endif  // MCPT_GPU_SHEEN_ALBEDO_TABLE_H\n");
    return 0;
}
