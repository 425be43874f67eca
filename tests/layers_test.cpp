// glTF's clearcoat and sheen over metallic-roughness (common/gpu/layers.h), run as the C++
// build of the device code: the sheen's albedo table against quadrature between its nodes,
// the layered sampler against its mixture density (chi-square), sample weights against the
// integral of f cos, the white furnace, and exact values where the model gives them. Each
// check has a negative control: a variant with the defect it looks for must fail it.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <functional>
#include <iterator>
#include <random>

#include "bsdf_checks.h"

namespace mcpt::gpu {
namespace {

GpuMaterial layered(vec3 base, float metallic, float roughness, float clearcoat,
                    float coat_roughness, vec3 sheen, float sheen_roughness) {
    GpuMaterial m{};
    m.r = base.x, m.g = base.y, m.b = base.z;
    m.type = MAT_PBR;
    m.ior = 1.5f;
    m.metallic = metallic;
    m.alpha = std::max(roughness * roughness, MIN_GGX_ALPHA);
    m.specular = 1.f;
    m.clearcoat = clearcoat;
    m.clearcoat_alpha = std::max(coat_roughness * coat_roughness, MIN_GGX_ALPHA);
    m.sheen_r = sheen.x, m.sheen_g = sheen.y, m.sheen_b = sheen.z;
    m.sheen_roughness = std::max(sheen_roughness, MIN_SHEEN_ROUGHNESS);
    m.tex_clearcoat = m.tex_sheen = NO_TEXTURE;
    return m;
}

// ------------------------------------------------------------------- the albedo table

// The table's E against quadrature of the lobe at points between its nodes (where the
// interpolation is worst): within 0.01 absolute or 3 % of the value.
double worst_table_error(const std::function<float(float cos, float roughness)>& lookup) {
    double worst = 0;
    for (float roughness : {0.1f, 0.33f, 0.5f, 0.81f, 0.97f}) {
        for (float cos_o : {0.1f, 0.23f, 0.5f, 0.77f, 0.95f}) {
            const vec3 wo = outgoing(cos_o);
            const double exact = hemisphere_integral(
                [&](vec3 wi) {
                    return double(sheen_lobe(wo, wi, normalize(wo + wi), roughness)) * wi.z;
                },
                300, 300);
            const double error =
                std::fabs(lookup(cos_o, roughness) - exact) / std::max(0.01, 0.03 * exact);
            worst = std::max(worst, error);
        }
    }
    return worst;
}

TEST(Layers, SheenAlbedoTableMatchesTheLobeBetweenItsNodes) {
    EXPECT_LT(worst_table_error(sheen_albedo), 1.0);
    // Control: the table read with roughness squared (as if indexed by Charlie's alpha).
    EXPECT_GT(worst_table_error([](float c, float r) { return sheen_albedo(c, r * r); }), 1.0);
}

// ------------------------------------------------------------ sampling against density

struct Case {
    const char* name;
    GpuMaterial m;
    float cos_o;
};

const Case kCases[] = {
    {"clearcoat over red plastic",
     layered(V3(0.8f, 0.1f, 0.1f), 0.f, 0.6f, 1.f, 0.1f, V3S(0.f), 0.f), 0.7f},
    {"clearcoat 0.5, rough, over metal, grazing",
     layered(V3(0.9f, 0.7f, 0.3f), 1.f, 0.3f, 0.5f, 0.5f, V3S(0.f), 0.f), 0.2f},
    {"sheen over dark cloth", layered(V3S(0.1f), 0.f, 0.8f, 0.f, 0.f, V3(0.9f, 0.6f, 0.4f), 0.4f),
     0.6f},
    {"sheen and clearcoat, grazing",
     layered(V3(0.2f, 0.4f, 0.7f), 0.f, 0.5f, 0.8f, 0.4f, V3S(1.f), 0.8f), 0.15f},
};

using Sampler = std::function<vec3(const GpuMaterial&, vec3 wo, vec3 u)>;

double sampling_p_value(const Case& c, const Sampler& sampler) {
    const vec3 wo = outgoing(c.cos_o);
    return direction_p_value([&](vec3 u) { return sampler(c.m, wo, u); },
                             [&](vec3 wi) { return coated_eval(c.m, wo, wi).pdf; }, 24, 0.f, 4242);
}

TEST(Layers, SampledDirectionsFollowTheirDensity) {
    const double level = stats::sidak_level(1e-3, std::size(kCases));
    for (const Case& c : kCases) {
        const double p = sampling_p_value(c, coated_sample_direction);
        EXPECT_GT(p, level) << c.name;
        std::printf("chi-square, %s: p = %.3f\n", c.name, p);
    }
    // Control: the coat drawn half as often as the density says (its share of u.z halved).
    const Sampler halved_coat = [](const GpuMaterial& m, vec3 wo, vec3 u) {
        const LayerChoice c = layer_choice(m, wo.z);
        if (u.z < 0.5f * c.coat) {
            const vec3 h = sample_ggx_vndf(wo, m.clearcoat_alpha, u.x, u.y);
            return h * (2.f * dot(wo, h)) - wo;
        }
        GpuMaterial bare = m;
        bare.clearcoat = 0.f;
        return coated_sample_direction(bare, wo, u);
    };
    const double p = sampling_p_value(kCases[0], halved_coat);
    EXPECT_LT(p, 1e-6);
    std::printf("chi-square, control (coat drawn half as often): p = %.3g\n", p);
}

// ------------------------------------------------------------ weights and the furnace

// Directional albedo of a layered material; `pdf_of` the density the weights divide by.
using PdfOf = std::function<float(const GpuMaterial&, vec3 wo, vec3 wi)>;
float mixture_pdf(const GpuMaterial& m, vec3 wo, vec3 wi) {
    return coated_eval(m, wo, wi).pdf;
}
Albedo albedo(const GpuMaterial& m, float cos_o, const PdfOf& pdf_of = mixture_pdf, int n = 100000,
              bool integrate = true) {
    const BsdfDraws b = {[&](vec3 wo, vec3 u) { return coated_sample_direction(m, wo, u); },
                         [&](vec3 wo, vec3 wi) { return pdf_of(m, wo, wi); },
                         [&](vec3 wo, vec3 wi) { return coated_eval(m, wo, wi).f; }};
    return directional_albedo(b, cos_o, n, integrate, 91);
}

TEST(Layers, SamplingWeightsIntegrateTheBsdf) {
    for (const Case& c : kCases) {
        const Albedo a = albedo(c.m, c.cos_o);
        EXPECT_NEAR(a.sampled, a.integrated, 4 * a.sampled_error + 2e-3) << c.name;
    }
    // Control: a mixture density that leaves out the sheen's share (what is drawn from the
    // sheen is then weighted as if the base had drawn it).
    const PdfOf no_sheen = [](const GpuMaterial& m, vec3 wo, vec3 wi) {
        const LayerChoice c = layer_choice(m, wo.z);
        return coated_eval(m, wo, wi).pdf - c.sheen * wi.z * float(1 / kPi);
    };
    const Albedo bad = albedo(kCases[2].m, kCases[2].cos_o, no_sheen);
    EXPECT_GT(std::fabs(bad.sampled - bad.integrated), 6 * bad.sampled_error + 2e-3);
}

// The white furnace: a white conductor (it reflects all but what single-scattering GGX loses)
// under a clear coat reflects no more than it receives, nor does white plastic under a coat,
// nor a white sheen over a white conductor above grazing angles. A coat added on top of the
// layers below, without taking its reflection from them, does (control).
TEST(Layers, WhiteFurnaceReflectsNoMoreThanItReceives) {
    struct Furnace {
        const char* name;
        GpuMaterial m;
    };
    const Furnace furnaces[] = {
        {"clearcoat 1 (roughness 0.05) over a white conductor (0.2)",
         layered(V3S(1.f), 1.f, 0.2f, 1.f, 0.05f, V3S(0.f), 0.f)},
        {"clearcoat 1 (roughness 0.6) over a white conductor (0.6)",
         layered(V3S(1.f), 1.f, 0.6f, 1.f, 0.6f, V3S(0.f), 0.f)},
        {"white sheen (roughness 0.3) over a white conductor (0.3)",
         layered(V3S(1.f), 1.f, 0.3f, 0.f, 0.f, V3S(1.f), 0.3f)},
        {"white sheen (roughness 1) and clearcoat over a white conductor",
         layered(V3S(1.f), 1.f, 0.3f, 1.f, 0.1f, V3S(1.f), 1.f)},
    };
    for (const Furnace& f : furnaces) {
        for (float cos_o : {1.f, 0.5f, 0.2f}) {
            const Albedo a = albedo(f.m, cos_o, mixture_pdf, 50000, false);
            EXPECT_LE(a.sampled, 1 + 4 * a.sampled_error + 1e-3) << f.name << ", cos " << cos_o;
            std::printf("%s, cos(wo) %.1f: E = %.4f +- %.4f\n", f.name, cos_o, a.sampled,
                        a.sampled_error);
        }
    }
    // Control: the coat added over the conductor without weighting it by 1 - F.
    const GpuMaterial m = furnaces[1].m;
    GpuMaterial bare = m;
    bare.clearcoat = 0.f;
    const vec3 wo = outgoing(0.2f);
    const double added = hemisphere_integral(
        [&](vec3 wi) {
            const vec3 h = normalize(wo + wi);
            const double coat =
                m.clearcoat * coat_fresnel(wo.z) * ggx_dv(wo, wi, h, m.clearcoat_alpha);
            return (mean_component(pbr_eval(bare, wo, wi).f) + coat) * wi.z;
        },
        900, 400);
    EXPECT_GT(added, 1.05);
    std::printf("control, coat added on top, cos(wo) 0.2: E = %.4f\n", added);
}

// Exact values: without layers the material is the base (bit for bit); a smooth coat over a
// black base reflects exactly the coat's Fresnel, 0.04 + 0.96 (1 - cos)^5 times its weight.
TEST(Layers, ExactWithoutLayersAndOverBlack) {
    const GpuMaterial base = layered(V3(0.7f, 0.4f, 0.2f), 0.3f, 0.5f, 0.f, 0.f, V3S(0.f), 0.f);
    std::mt19937 rng(5);
    std::uniform_real_distribution<float> uni(0.f, 1.f);
    const vec3 wo = outgoing(0.6f);
    for (int i = 0; i < 200; ++i) {
        const vec3 u = V3(uni(rng), uni(rng), uni(rng));
        const vec3 wi = coated_sample_direction(base, wo, u);
        EXPECT_EQ(wi, pbr_sample_direction(base, wo, u));
        EXPECT_EQ(coated_eval(base, wo, wi).f, pbr_eval(base, wo, wi).f);
        EXPECT_EQ(coated_eval(base, wo, wi).pdf, pbr_eval(base, wo, wi).pdf);
    }
    GpuMaterial black = layered(V3S(0.f), 0.f, 0.5f, 0.75f, 0.01f, V3S(0.f), 0.f);
    black.specular = 0.f;  // no dielectric layer below the coat either
    for (float cos_o : {1.f, 0.5f}) {
        const Albedo a = albedo(black, cos_o, mixture_pdf, 20000, false);
        const double exact = 0.75 * coat_fresnel(cos_o);
        EXPECT_NEAR(a.sampled, exact, 2e-3 * exact) << "cos " << cos_o;
        // Control: the coat's Fresnel at the ior of water (F0 = 0.02) is not it.
        EXPECT_GT(std::fabs(0.75 * (0.02 + 0.98 * std::pow(1 - cos_o, 5)) - a.sampled),
                  0.1 * exact);
    }
}

}  // namespace
}  // namespace mcpt::gpu
