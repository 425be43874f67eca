// Materials: Lambertian diffuse, perfect mirror, smooth dielectric (Fresnel, total internal
// reflection), glTF metallic-roughness with its layers (microfacet.h, layers.h) and rough
// dielectric (microfacet.h). Directions point away from the surface; `n` faces the side of
// `wo`.
#ifndef MCPT_GPU_BSDF_H
#define MCPT_GPU_BSDF_H

#include "layers.h"
#include "microfacet.h"
#include "sampling.h"
#include "scene_access.h"  // HAS_FEATURE

MCPT_NAMESPACE_BEGIN

MCPT_STRUCT(BsdfSample) {
    vec3 wi;
    vec3 weight;  // f * |cos| / pdf
    float pdf;    // solid-angle pdf; 0 for delta lobes
    float eta2;   // squared relative IOR crossed (1 unless refracted)
    bool specular;
    bool valid;
};

MCPT_FN vec3 material_color(GpuMaterial m) { return V3(m.r, m.g, m.b); }
MCPT_FN vec3 material_emission(GpuMaterial m) { return V3(m.er, m.eg, m.eb); }

// Absorbing glass's coefficient per unit length (MAT_VOLUME): `metallic` holds the largest
// channel, `specular`'s bits the three channels over it in steps of 1/1023.
MCPT_FN vec3 material_sigma(GpuMaterial m) {
    uint bits = float_as_uint(m.specular);
    vec3 ratio = V3(F32(bits & 1023u), F32((bits >> 10u) & 1023u), F32((bits >> 20u) & 1023u));
    return ratio * (m.metallic * (1.0f / 1023.0f));
}

// Beer-Lambert: the fraction of light left after a distance t through coefficient sigma
// (exactly 1 in a channel that does not absorb, t = MCPT_FLT_MAX included).
MCPT_FN vec3 transmittance(vec3 sigma, float t) {
    return V3(exp(-MINF(sigma.x * t, 100.0f)), exp(-MINF(sigma.y * t, 100.0f)),
              exp(-MINF(sigma.z * t, 100.0f)));
}

// Whether a triangle of this material emits from its back face too (glTF doubleSided). The
// BSDFs below read m.type as the kind alone: shade_vertex clears the flags first.
MCPT_FN bool emits_from_back(GpuMaterial m) { return (m.type & MAT_TWO_SIDED) != 0u; }

MCPT_FN vec3 reflect_about(vec3 wo, vec3 n) { return n * (2.0f * dot(wo, n)) - wo; }

// Lambertian: f = albedo / pi.
MCPT_FN vec3 diffuse_eval(GpuMaterial m, vec3 n, vec3 wi) {
    return dot(n, wi) > 0.0f ? material_color(m) * MCPT_INV_PI : V3S(0.0f);
}
MCPT_FN float diffuse_pdf(vec3 n, vec3 wi) { return MAXF(0.0f, dot(n, wi)) * MCPT_INV_PI; }

// Whether next-event estimation and MIS apply: materials with a non-delta lobe.
MCPT_FN bool has_smooth_lobe(GpuMaterial m) {
    if (HAS_FEATURE(FEATURE_DIFFUSE) && m.type == MAT_DIFFUSE) return true;
    return HAS_FEATURE(FEATURE_MICROFACET) && (m.type == MAT_PBR || m.type == MAT_ROUGH_GLASS);
}

// Whether a material scatters light through the surface as well (next-event estimation then
// looks for lights on both sides).
MCPT_FN bool is_transmissive(GpuMaterial m) {
    return HAS_FEATURE(FEATURE_MICROFACET) && m.type == MAT_ROUGH_GLASS;
}

// f(wo, wi) and the pdf with which sample_bsdf() draws wi, for materials with a smooth lobe;
// `entering`: wo is on the outside (for the rough dielectric's relative IOR).
MCPT_FN BsdfEval eval_bsdf(GpuMaterial m, vec3 n, vec3 wo, vec3 wi, bool entering) {
    BsdfEval e;
    if (HAS_FEATURE(FEATURE_MICROFACET) && m.type == MAT_PBR) {
        Frame fr = frame_from_normal(n);
        return coated_eval(m, frame_to_local(fr, wo), frame_to_local(fr, wi));
    }
    if (HAS_FEATURE(FEATURE_MICROFACET) && m.type == MAT_ROUGH_GLASS) {
        Frame fr = frame_from_normal(n);
        float eta = entering ? m.ior : DIVF(1.0f, m.ior);
        return rough_dielectric_eval(frame_to_local(fr, wo), frame_to_local(fr, wi), eta,
                                     material_alpha(m), material_color(m));
    }
    e.f = diffuse_eval(m, n, wi);
    e.pdf = diffuse_pdf(n, wi);
    return e;
}

// Sample the material at a point with normal n (facing wo); `entering` tells whether wo is
// on the outside of the surface (for glass). u = three uniforms.
MCPT_FN BsdfSample sample_bsdf(GpuMaterial m, vec3 n, vec3 wo, bool entering, vec3 u) {
    BsdfSample s;
    s.wi = n;
    s.weight = V3S(0.0f);
    s.pdf = 0.0f;
    s.eta2 = 1.0f;
    s.specular = true;
    s.valid = true;
    if (HAS_FEATURE(FEATURE_DIFFUSE) && m.type == MAT_DIFFUSE) {
        // Cosine-weighted hemisphere: weight = albedo.
        s.wi = frame_to_world(frame_from_normal(n), sample_cosine_hemisphere(u.x, u.y));
        s.pdf = diffuse_pdf(n, s.wi);
        s.weight = material_color(m);
        s.specular = false;
        s.valid = s.pdf > 0.0f;
    } else if (HAS_FEATURE(FEATURE_MICROFACET) && m.type == MAT_PBR) {
        // Metallic-roughness: one lobe drawn, weighted by the pdf of both.
        Frame fr = frame_from_normal(n);
        vec3 wo_l = frame_to_local(fr, wo);
        vec3 wi_l = coated_sample_direction(m, wo_l, u);
        BsdfEval e = coated_eval(m, wo_l, wi_l);
        s.wi = frame_to_world(fr, wi_l);
        s.pdf = e.pdf;
        s.specular = false;
        s.valid = e.pdf > 0.0f;
        s.weight = s.valid ? e.f * DIVF(wi_l.z, e.pdf) : V3S(0.0f);
    } else if (HAS_FEATURE(FEATURE_MICROFACET) && m.type == MAT_ROUGH_GLASS) {
        // Rough dielectric: reflect or refract through a visible normal.
        Frame fr = frame_from_normal(n);
        float eta = entering ? m.ior : DIVF(1.0f, m.ior);
        float alpha = material_alpha(m);
        vec3 wo_l = frame_to_local(fr, wo);
        vec3 wi_l = rough_dielectric_sample_direction(wo_l, eta, alpha, u);
        BsdfEval e = rough_dielectric_eval(wo_l, wi_l, eta, alpha, material_color(m));
        s.wi = frame_to_world(fr, wi_l);
        s.pdf = e.pdf;
        s.specular = false;
        s.valid = e.pdf > 0.0f;
        s.weight = s.valid ? e.f * DIVF(ABSF(wi_l.z), e.pdf) : V3S(0.0f);
        s.eta2 = wi_l.z < 0.0f ? eta * eta : 1.0f;
    } else if (HAS_FEATURE(FEATURE_MIRROR) && m.type == MAT_MIRROR) {
        s.wi = reflect_about(wo, n);
        s.weight = material_color(m);
    } else if (HAS_FEATURE(FEATURE_GLASS) && m.type == MAT_GLASS) {
        // Dielectric: reflect with probability F, else refract (radiance scales by 1/eta^2).
        float eta = entering ? m.ior : DIVF(1.0f, m.ior);
        float cos_i = MINF(1.0f, dot(wo, n));
        float f = fresnel_dielectric(cos_i, eta);
        if (u.z < f) {
            s.wi = reflect_about(wo, n);
            s.weight = V3S(1.0f);
        } else {
            float sin2_t = DIVF(MAXF(0.0f, 1.0f - cos_i * cos_i), eta * eta);
            float cos_t = sqrt(MAXF(0.0f, 1.0f - sin2_t));
            s.wi = normalize(DIVF(-wo, eta) + n * (DIVF(cos_i, eta) - cos_t));
#ifdef MCPT_NEGATIVE_CONTROL_NO_REFRACTION
            s.valid = false;  // tests: a variant that drops transmission through glass
#endif
            s.eta2 = eta * eta;
            s.weight = DIVF(material_color(m), s.eta2);
        }
    } else {
        s.valid = false;  // a material this build left out: never happens (scene_features.h)
    }
    return s;
}

MCPT_NAMESPACE_END

#endif  // MCPT_GPU_BSDF_H
