// glTF 2.0 metallic-roughness (MAT_PBR): a GGX microfacet specular lobe with Schlick's Fresnel
// over a Lambertian base (glTF's fresnel_mix, with KHR_materials_specular's factor), blended
// with a GGX conductor tinted by the base color (glTF's conductor_fresnel) by `metallic`.
// Visible normals are sampled as in Heitz 2018; the masking-shadowing term is Smith's
// height-correlated one. Everything here works in the local frame of the normal (n = +z),
// with wo.z > 0 (the integrator turns the normal toward wo).
#ifndef MCPT_GPU_MICROFACET_H
#define MCPT_GPU_MICROFACET_H

#include "sampling.h"
#include "shared_types.h"

MCPT_NAMESPACE_BEGIN

MCPT_FN vec3 frame_to_local(Frame f, vec3 v) {
    return V3(dot(v, f.t), dot(v, f.b), dot(v, f.n));
}

// GGX normal distribution of a unit half vector h; written with tan^2 / alpha^2 so that it
// stays exact for alpha near MIN_GGX_ALPHA.
MCPT_FN float ggx_d(vec3 h, float alpha) {
    if (h.z <= 0.0f) return 0.0f;
    float a2 = alpha * alpha;
    float t = DIVF(h.x * h.x + h.y * h.y, a2) + h.z * h.z;
    return DIVF(1.0f, MCPT_PI * a2 * t * t);
}

// sqrt(cos^2 + alpha^2 sin^2) of a direction: Smith's Lambda(w) = (ggx_root(w) / cos - 1) / 2.
MCPT_FN float ggx_root(vec3 w, float alpha) {
    return sqrt(w.z * w.z + alpha * alpha * (w.x * w.x + w.y * w.y));
}

// Smith masking of one direction, G1 = 1 / (1 + Lambda) (no division by cos).
MCPT_FN float ggx_g1(vec3 w, float alpha) {
    float c = ABSF(w.z);
    return DIVF(2.0f * c, c + ggx_root(w, alpha));
}

// D * G2 / (4 cos_o cos_i) with Smith's height-correlated G2 = 1 / (1 + Lambda_o + Lambda_i):
// the specular lobe without Fresnel (glTF's V_GGX * D_GGX). wo.z, wi.z > 0.
MCPT_FN float ggx_dv(vec3 wo, vec3 wi, vec3 h, float alpha) {
    float denom = wi.z * ggx_root(wo, alpha) + wo.z * ggx_root(wi, alpha);
    return denom > 0.0f ? DIVF(ggx_d(h, alpha) * 0.5f, denom) : 0.0f;
}

// A visible normal of the GGX surface seen from wo (Heitz 2018): density
// D_wo(h) = G1(wo) max(0, wo.h) D(h) / wo.z.
MCPT_FN vec3 sample_ggx_vndf(vec3 wo, float alpha, float u1, float u2) {
    // The direction in the hemisphere configuration (alpha = 1).
    vec3 vh = normalize(V3(alpha * wo.x, alpha * wo.y, wo.z));
    // An orthonormal basis around it.
    float len2 = vh.x * vh.x + vh.y * vh.y;
    vec3 t1 = len2 > 0.0f ? V3(-vh.y, vh.x, 0.0f) * inversesqrt(len2) : V3(1.0f, 0.0f, 0.0f);
    vec3 t2 = cross(vh, t1);
    // A point on the projected disk, warped to the visible half.
    float r = sqrt(u1);
    float phi = 2.0f * MCPT_PI * u2;
    float p1 = r * COSF(phi);
    float p2 = r * SINF(phi);
    float s = 0.5f * (1.0f + vh.z);
    p2 = (1.0f - s) * sqrt(MAXF(0.0f, 1.0f - p1 * p1)) + s * p2;
    // Back onto the hemisphere, then to the ellipsoid configuration.
    vec3 nh = t1 * p1 + t2 * p2 + vh * sqrt(MAXF(0.0f, 1.0f - p1 * p1 - p2 * p2));
    return normalize(V3(alpha * nh.x, alpha * nh.y, MAXF(1.0e-7f, nh.z)));
}

// Solid-angle density of wi = reflect(wo, h) for h drawn by sample_ggx_vndf:
// D_wo(h) / (4 wo.h) = G1(wo) D(h) / (4 wo.z).
MCPT_FN float ggx_reflection_pdf(vec3 wo, vec3 h, float alpha) {
    return DIVF(ggx_g1(wo, alpha) * ggx_d(h, alpha), 4.0f * wo.z);
}

// Unpolarized Fresnel reflectance of a dielectric; cos_i > 0, eta = n_transmitted / n_incident.
MCPT_FN float fresnel_dielectric(float cos_i, float eta) {
    float sin2_t = DIVF(1.0f - cos_i * cos_i, eta * eta);
    if (sin2_t >= 1.0f) return 1.0f;  // total internal reflection
    float cos_t = sqrt(MAXF(0.0f, 1.0f - sin2_t));
    float r_par = DIVF(eta * cos_i - cos_t, eta * cos_i + cos_t);
    float r_perp = DIVF(cos_i - eta * cos_t, cos_i + eta * cos_t);
    return 0.5f * (r_par * r_par + r_perp * r_perp);
}

// Smith's height-correlated G2 of two directions on either side: 2 |c_o| |c_i| / (|c_i| r_o +
// |c_o| r_i) with r = ggx_root.
MCPT_FN float ggx_g2(vec3 wo, vec3 wi, float alpha) {
    float co = ABSF(wo.z), ci = ABSF(wi.z);
    float denom = ci * ggx_root(wo, alpha) + co * ggx_root(wi, alpha);
    return denom > 0.0f ? DIVF(2.0f * co * ci, denom) : 0.0f;
}

MCPT_FN float pow5(float x) {
    float x2 = x * x;
    return x2 * x2 * x;
}

// The dielectric Fresnel reflectance at normal incidence: ((ior - 1) / (ior + 1))^2.
MCPT_FN float dielectric_f0(float ior) {
    float r = DIVF(ior - 1.0f, ior + 1.0f);
    return r * r;
}

// The material's GGX alpha. Tests build a variant 1.x times rougher in one backend
// (MCPT_NEGATIVE_CONTROL_GGX_ALPHA=x), which mcpt compare must reject.
MCPT_FN float material_alpha(GpuMaterial m) {
#ifdef MCPT_NEGATIVE_CONTROL_GGX_ALPHA
    return m.alpha * MCPT_NEGATIVE_CONTROL_GGX_ALPHA;
#else
    return m.alpha;
#endif
}

// BSDF value (f, without the cosine) and the solid-angle pdf with which pbr_sample() draws wi.
MCPT_STRUCT(BsdfEval) {
    vec3 f;
    float pdf;
};

// The specular and the diffuse lobe's estimated albedo at wo (Fresnel at cos_o, masking
// ignored): what the lobe choice weighs.
MCPT_FN vec2 pbr_lobe_albedos(GpuMaterial m, vec3 base, float cos_o) {
    float fw = pow5(1.0f - cos_o);
    float f0 = dielectric_f0(m.ior);
    float fd = m.specular * (f0 + (1.0f - f0) * fw);
    float spec =
        (1.0f - m.metallic) * fd + m.metallic * mean_component(base + (V3S(1.0f) - base) * fw);
    float diff = (1.0f - m.metallic) * (1.0f - fd) * mean_component(base);
    return V2(spec, diff);
}

// Probability that pbr_sample() takes the specular lobe: its Fresnel-weighted share at wo.
MCPT_FN float pbr_specular_probability(GpuMaterial m, vec3 base, float cos_o) {
    vec2 a = pbr_lobe_albedos(m, base, cos_o);
    return a.x + a.y > 0.0f ? a.x / (a.x + a.y) : 1.0f;
}

// f(wo, wi) and pdf of MAT_PBR in the local frame (glTF 2.0 Appendix B).
MCPT_FN BsdfEval pbr_eval(GpuMaterial m, vec3 wo, vec3 wi) {
    BsdfEval e;
    e.f = V3S(0.0f);
    e.pdf = 0.0f;
    if (wo.z <= 0.0f || wi.z <= 0.0f) return e;
    vec3 base = V3(m.r, m.g, m.b);
    vec3 h = normalize(wo + wi);
    float fw = pow5(1.0f - MINF(1.0f, MAXF(0.0f, dot(wo, h))));
    // Fresnel of the dielectric layer and of the conductor.
    float f0 = dielectric_f0(m.ior);
    float fd = m.specular * (f0 + (1.0f - f0) * fw);
    vec3 fm = base + (V3S(1.0f) - base) * fw;
    float alpha = material_alpha(m);
    float dv = ggx_dv(wo, wi, h, alpha);
    e.f = base * ((1.0f - m.metallic) * (1.0f - fd) * MCPT_INV_PI) +
          (fm * m.metallic + V3S((1.0f - m.metallic) * fd)) * dv;
    float p_spec = pbr_specular_probability(m, base, wo.z);
    e.pdf = p_spec * ggx_reflection_pdf(wo, h, alpha) + (1.0f - p_spec) * wi.z * MCPT_INV_PI;
    return e;
}

// Draws wi (local frame) for MAT_PBR: the specular lobe by visible normals or the diffuse base
// by cosine, chosen by u.z; wi.z <= 0 (a reflection below the surface) means no sample.
MCPT_FN vec3 pbr_sample_direction(GpuMaterial m, vec3 wo, vec3 u) {
    float p_spec = pbr_specular_probability(m, V3(m.r, m.g, m.b), wo.z);
    if (u.z < p_spec) {
        vec3 h = sample_ggx_vndf(wo, material_alpha(m), u.x, u.y);
        return h * (2.0f * dot(wo, h)) - wo;
    }
    return sample_cosine_hemisphere(u.x, u.y);
}

// Rough dielectric (Walter et al. 2007; as pbrt-v4's DielectricBxDF) in the local frame,
// wo.z > 0; eta = IOR beyond the surface / IOR on wo's side. f for radiance (transmission
// scaled by 1 / eta^2 and tinted by `tint`) and the pdf of rough_dielectric_sample_direction.
MCPT_FN BsdfEval rough_dielectric_eval(vec3 wo, vec3 wi, float eta, float alpha, vec3 tint) {
    BsdfEval e;
    e.f = V3S(0.0f);
    e.pdf = 0.0f;
    if (wo.z <= 0.0f || wi.z == 0.0f) return e;
    bool reflected = wi.z > 0.0f;
    // The generalized half vector, on the normal's side.
    vec3 wm = wi * (reflected ? 1.0f : eta) + wo;
    float len2 = dot(wm, wm);
    if (!(len2 > 0.0f)) return e;
    wm = wm * inversesqrt(len2);
    if (wm.z < 0.0f) wm = -wm;
    // Microfacets seen from behind by either direction contribute nothing.
    float dwo = dot(wo, wm), dwi = dot(wi, wm);
    if (dwo <= 0.0f || dwi * wi.z <= 0.0f) return e;
    float f = fresnel_dielectric(dwo, eta);
    float d = ggx_d(wm, alpha);
    float g2 = ggx_g2(wo, wi, alpha);
    float visible = DIVF(ggx_g1(wo, alpha) * dwo * d, wo.z);  // D_wo(wm)
    if (reflected) {
        e.f = V3S(DIVF(f * d * g2, 4.0f * wo.z * wi.z));
        e.pdf = DIVF(f * visible, 4.0f * dwo);
        return e;
    }
    float denom = dwi + DIVF(dwo, eta);
    denom = denom * denom;
#ifdef MCPT_NEGATIVE_CONTROL_NO_FRESNEL_T
    f = 0.0f;  // tests: a variant that transmits what it also reflects
#endif
    float ft = DIVF((1.0f - f) * d * g2 * ABSF(DIVF(dwi * dwo, wi.z * wo.z * denom)), eta * eta);
    e.f = tint * ft;
    e.pdf = DIVF((1.0f - fresnel_dielectric(dwo, eta)) * visible * ABSF(dwi), denom);
    return e;
}

// A direction for the rough dielectric: a visible normal, then reflection with the Fresnel
// probability, else refraction through it. A reflection below the surface or a refraction
// above it is no sample: the zero vector (which rough_dielectric_eval gives pdf 0).
MCPT_FN vec3 rough_dielectric_sample_direction(vec3 wo, float eta, float alpha, vec3 u) {
    vec3 h = sample_ggx_vndf(wo, alpha, u.x, u.y);
    float cos_o = dot(wo, h);
    vec3 wi;
    if (u.z < fresnel_dielectric(cos_o, eta)) {
        wi = h * (2.0f * cos_o) - wo;
        return wi.z > 0.0f ? wi : V3S(0.0f);
    }
    float sin2_t = DIVF(MAXF(0.0f, 1.0f - cos_o * cos_o), eta * eta);
    float cos_t = sqrt(MAXF(0.0f, 1.0f - sin2_t));
    wi = normalize(DIVF(-wo, eta) + h * (DIVF(cos_o, eta) - cos_t));
    return wi.z < 0.0f ? wi : V3S(0.0f);
}

MCPT_NAMESPACE_END

#endif  // MCPT_GPU_MICROFACET_H
