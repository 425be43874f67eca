// glTF's layers over metallic-roughness (MAT_PBR), as the glTF 2.0 extensions combine them:
//   KHR_materials_sheen: the Charlie sheen lobe (Conty Estevez & Kulla 2017: the distribution
//     and their fitted masking, as the glTF Sample Viewer writes them), over the base scaled
//     by 1 - max(sheen color) * E (E: the lobe's directional albedo, sheen_albedo_table.h),
//     at the larger of the two directions' E, and at least 0 (the lobe reflects more than it
//     receives at grazing angles: E above 1 below cos 0.04, up to 1.64, docs/materials.md);
//   KHR_materials_clearcoat: a clear GGX coat of ior 1.5 over both, the layers below weighted
//     by 1 - clearcoat * F(cos_o) and the coat by clearcoat * F(cos_o) (glTF's fresnel_coat).
// One lobe is sampled, chosen by its share of the albedo at wo; the pdf is the mixture's.
// The coat takes the base's shading normal (glTF's clearcoatNormalTexture is not read).
#ifndef MCPT_GPU_LAYERS_H
#define MCPT_GPU_LAYERS_H

#include "microfacet.h"
#include "scene_access.h"  // HAS_FEATURE
#include "sheen_albedo_table.h"

MCPT_NAMESPACE_BEGIN

// The sheen's albedo table: a constant array in C++ and OpenCL C; GLSL reads the copy the host
// put after texels_word (lavapipe took minutes to compile the array as a GLSL constant).
#if defined(MCPT_GLSL)
#define SHEEN_ALBEDO_AT(i) uintBitsToFloat(SCENE_WORD(params.sheen_albedo_word + (i)))
#else
#define SHEEN_ALBEDO_AT(i) SHEEN_ALBEDO[i]
#endif

// ------------------------------------------------------------------------------- sheen

// Charlie's distribution of a unit half vector: (2 + 1/alpha) sin^(1/alpha) / (2 pi).
MCPT_FN float charlie_d(float cos_h, float alpha) {
    float inv = DIVF(1.0f, alpha);
    float sin2 = MAXF(0.0f, 1.0f - cos_h * cos_h);
    return (2.0f + inv) * pow(sin2, 0.5f * inv) * (0.5f * MCPT_INV_PI);
}

// Conty Estevez & Kulla's fit of the sheen's Lambda, interpolated in (1 - alpha)^2.
MCPT_FN float sheen_lambda_fit(float x, float alpha) {
    float t = (1.0f - alpha) * (1.0f - alpha);
    float a = mix(21.5473f, 25.3245f, t), b = mix(3.82987f, 3.32435f, t);
    float c = mix(0.19823f, 0.16801f, t), d = mix(-1.97760f, -1.27393f, t);
    float e = mix(-4.32054f, -4.85967f, t);
    return DIVF(a, 1.0f + b * pow(x, c)) + d * x + e;
}
MCPT_FN float sheen_lambda(float cos_t, float alpha) {
    return cos_t < 0.5f
               ? exp(sheen_lambda_fit(cos_t, alpha))
               : exp(2.0f * sheen_lambda_fit(0.5f, alpha) - sheen_lambda_fit(1.0f - cos_t, alpha));
}

// The sheen lobe without its color: D V, V = 1 / ((1 + Lambda_o + Lambda_i) 4 cos_o cos_i)
// clamped to 1 as the Sample Viewer does. wo.z, wi.z > 0.
MCPT_FN float sheen_lobe(vec3 wo, vec3 wi, vec3 h, float roughness) {
    float alpha = roughness * roughness;
    float v = DIVF(1.0f, (1.0f + sheen_lambda(wo.z, alpha) + sheen_lambda(wi.z, alpha)) *
                             (4.0f * wo.z * wi.z));
    return charlie_d(h.z, alpha) * MINF(v, 1.0f);
}

// The lobe's directional albedo E(cos, roughness): the table, bilinear in the square roots
// of cos and of roughness over its range (its nodes close where E changes fastest: at
// grazing angles and low roughness).
MCPT_FN float sheen_albedo(float cos_t, float roughness) {
    float x = sqrt(clamp(cos_t, 0.0f, 1.0f)) * F32(SHEEN_ALBEDO_COS - 1u);
    float y =
        sqrt(clamp(DIVF(roughness - MIN_SHEEN_ROUGHNESS, 1.0f - MIN_SHEEN_ROUGHNESS), 0.0f, 1.0f)) *
        F32(SHEEN_ALBEDO_ROUGHNESS - 1u);
    uint x0 = min(U32(x), SHEEN_ALBEDO_COS - 2u), y0 = min(U32(y), SHEEN_ALBEDO_ROUGHNESS - 2u);
    float ax = x - F32(x0), ay = y - F32(y0);
    uint i = y0 * SHEEN_ALBEDO_COS + x0;
    float top = mix(SHEEN_ALBEDO_AT(i), SHEEN_ALBEDO_AT(i + 1u), ax);
    float bottom =
        mix(SHEEN_ALBEDO_AT(i + SHEEN_ALBEDO_COS), SHEEN_ALBEDO_AT(i + SHEEN_ALBEDO_COS + 1u), ax);
    return mix(top, bottom, ay);
}

// ------------------------------------------------------------------------------- coat

// The coat's Fresnel reflectance at cos_o (Schlick, ior 1.5: F0 = 0.04).
MCPT_FN float coat_fresnel(float cos_o) {
    return 0.04f + 0.96f * pow5(1.0f - cos_o);
}

// ------------------------------------------------------------------------------- layers

MCPT_FN vec3 sheen_color(GpuMaterial m) {
    return V3(m.sheen_r, m.sheen_g, m.sheen_b);
}
MCPT_FN bool has_clearcoat(GpuMaterial m) {
    return HAS_FEATURE(FEATURE_CLEARCOAT) && m.clearcoat > 0.0f;
}
MCPT_FN bool has_sheen(GpuMaterial m) {
    return HAS_FEATURE(FEATURE_SHEEN) && fmax3(m.sheen_r, m.sheen_g, m.sheen_b) > 0.0f;
}

// Which lobe to sample at wo: the coat's, the sheen's and the base's share of the albedo
// (they sum to 1); and what eval reuses: the coat's weight c F(cos_o), the sheen's E(cos_o).
MCPT_STRUCT(LayerChoice) {
    float coat, sheen, base;
    float coat_weight, sheen_albedo_o;
};
MCPT_FN LayerChoice layer_choice(GpuMaterial m, float cos_o) {
    float fc = has_clearcoat(m) ? m.clearcoat * coat_fresnel(cos_o) : 0.0f;
    float es = has_sheen(m) ? sheen_albedo(cos_o, m.sheen_roughness) : 0.0f;
    vec3 sc = sheen_color(m);
    vec2 lobes = pbr_lobe_albedos(m, V3(m.r, m.g, m.b), cos_o);
    LayerChoice c;
    c.coat_weight = fc, c.sheen_albedo_o = es;
    c.coat = fc;
    c.sheen = (1.0f - fc) * mean_component(sc) * es;
    c.base = (1.0f - fc) * MAXF(0.0f, 1.0f - fmax3(sc.x, sc.y, sc.z) * es) * (lobes.x + lobes.y);
    float sum = c.coat + c.sheen + c.base;
    if (!(sum > 0.0f)) {
        c.coat = 0.0f, c.sheen = 0.0f, c.base = 1.0f;
        return c;
    }
    c.coat = DIVF(c.coat, sum), c.sheen = DIVF(c.sheen, sum);
    c.base = MAXF(0.0f, 1.0f - c.coat - c.sheen);
    return c;
}

// f(wo, wi) and pdf of MAT_PBR with its layers, in the local frame.
MCPT_FN BsdfEval coated_eval(GpuMaterial m, vec3 wo, vec3 wi) {
    BsdfEval e = pbr_eval(m, wo, wi);
    bool coat = has_clearcoat(m), sheen = has_sheen(m);
    if ((!coat && !sheen) || wo.z <= 0.0f || wi.z <= 0.0f) return e;
    LayerChoice c = layer_choice(m, wo.z);
    vec3 h = normalize(wo + wi);
    e.pdf *= c.base;
    if (sheen) {
        vec3 sc = sheen_color(m);
        float e_max = MAXF(c.sheen_albedo_o, sheen_albedo(wi.z, m.sheen_roughness));
        e.f = e.f * MAXF(0.0f, 1.0f - fmax3(sc.x, sc.y, sc.z) * e_max) +
              sc * sheen_lobe(wo, wi, h, m.sheen_roughness);
        e.pdf += c.sheen * wi.z * MCPT_INV_PI;
    }
    if (coat) {
        float fc = c.coat_weight;
        e.f = e.f * (1.0f - fc) + V3S(fc * ggx_dv(wo, wi, h, m.clearcoat_alpha));
        e.pdf += c.coat * ggx_reflection_pdf(wo, h, m.clearcoat_alpha);
    }
    return e;
}

// Draws wi (local frame) for MAT_PBR with its layers: the coat by its visible normals, the
// sheen by cosine, or the base (pbr_sample_direction), chosen by u.z.
MCPT_FN vec3 coated_sample_direction(GpuMaterial m, vec3 wo, vec3 u) {
    if (!has_clearcoat(m) && !has_sheen(m)) return pbr_sample_direction(m, wo, u);
    LayerChoice c = layer_choice(m, wo.z);
    if (u.z < c.coat) {
        vec3 h = sample_ggx_vndf(wo, m.clearcoat_alpha, u.x, u.y);
        return h * (2.0f * dot(wo, h)) - wo;
    }
    if (u.z < c.coat + c.sheen) return sample_cosine_hemisphere(u.x, u.y);
    // The base, with u.z rescaled to its share.
    u.z = c.base > 0.0f ? MINF(DIVF(u.z - c.coat - c.sheen, c.base), 0.99999994f) : 0.0f;
    return pbr_sample_direction(m, wo, u);
}

MCPT_NAMESPACE_END

#endif  // MCPT_GPU_LAYERS_H
