// Next-event estimation's light choice and the densities it samples with: a point on an
// emissive triangle or rectangle (by solid angle, triangle_light.h and rect_light.h), a sphere
// light's cone, a punctual light or the environment (lights.h), picked by power or by the
// light tree (light_tree.h) (sample_light); and the solid-angle pdf with which it would have
// reached an emitter a BSDF-sampled ray hit, for that ray's MIS weight (emitter_hit_pdf): one
// pdf for both strategies. Shared verbatim by OpenCL C, GLSL and C++ (integrator.h includes
// it).
#ifndef MCPT_GPU_LIGHT_CHOICE_H
#define MCPT_GPU_LIGHT_CHOICE_H

#include "light_tree.h"
#include "lights.h"
#include "rect_light.h"
#include "surface_point.h"
#include "triangle_light.h"

MCPT_NAMESPACE_BEGIN

// The scene picks local lights by the light tree (else every light by power).
#define LIGHT_TREE_ON (HAS_FEATURE(FEATURE_LIGHT_TREE) && PARAM(num_tree_lights) > 0u)

MCPT_FN float triangle_area(GpuTriangle tri) {
    return 0.5f * length(cross(tri_v1(tri) - tri_v0(tri), tri_v2(tri) - tri_v0(tri)));
}

// Probability that next-event estimation at x picks emitter `light_prim` (a triangle index,
// or a sphere index | LIGHT_SPHERE_BIT) of material m, over its area: by power, mean(Le) /
// total (the pick is area * mean(Le) / total, twice that for a two-sided emitter), or by the
// tree, its pick's probability over the area.
MCPT_FN float emitter_area_pdf(SCENE_PARAMS_ uint light_prim, vec3 x, vec3 rn, GpuMaterial m,
                               float area) {
    if (LIGHT_TREE_ON)
        return DIVF(PARAM(light_tree_pmf) *
                        light_tree_pmf(SCENE_ARGS_ x, rn, light_tree_trail(SCENE_ARGS_ light_prim)),
                    area);
    float faces = emits_from_back(m) ? 2.0f : 1.0f;
    return DIVF(faces * mean_component(material_emission(m)), PARAM(light_power_total));
}

// Probability that next-event estimation at x picks emitter triangle `prim` (of material m
// and area `area`): by the tree, or by power.
MCPT_FN float triangle_pick_pmf(SCENE_PARAMS_ uint prim, vec3 x, vec3 rn, GpuMaterial m,
                                float area) {
    return emitter_area_pdf(SCENE_ARGS_ prim, x, rn, m, area) * area;
}

// Solid-angle pdf that next-event estimation samples a sphere light from x (cone sampling),
// the sphere picked with probability pmf.
MCPT_FN float sphere_cone_pdf(GpuSphere sph, vec3 x, float pmf) {
    vec3 to_c = V3(sph.cx, sph.cy, sph.cz) - x;
    float r2 = sph.radius * sph.radius;
    float d2 = dot(to_c, to_c);
    if (d2 <= r2) return 0.0f;  // inside: never sampled from here
    return DIVF(pmf, 2.0f * MCPT_PI * one_minus_cos_cone(r2 / d2));
}

MCPT_FN float sphere_light_pdf(SCENE_PARAMS_ uint index, vec3 x, vec3 rn) {
    GpuSphere sph = SPHERE(index);
    float pmf = LIGHT_TREE_ON
                    ? PARAM(light_tree_pmf) *
                          light_tree_pmf(SCENE_ARGS_ x, rn,
                                         light_tree_trail(SCENE_ARGS_ index | LIGHT_SPHERE_BIT))
                    : 4.0f * MCPT_PI * sph.radius * sph.radius *
                          emitter_area_pdf(SCENE_ARGS_ index | LIGHT_SPHERE_BIT, x, rn,
                                           MATERIAL(sph.material), 1.0f);
    return sphere_cone_pdf(sph, x, pmf);
}

// Choose a light by power (alias table) or by the tree (receiver normal rn, or 0), then a
// point on it, a direction of it, seen from x (shading normal ns: emissive triangles' samples
// follow its cosine). u: 3 uniforms.
MCPT_FN LightSample sample_light(SCENE_PARAMS_ vec3 x, vec3 rn, vec3 ns, vec3 u) {
    LightSample ls = no_light_sample();
    // A local light by the tree, or (without one, or else) one from the alias table: of every
    // light, or with a tree of the lights at infinity.
    uint count = PARAM(num_lights);
    float pick = u.x;
    bool by_tree = false;
    float tree_pmf = 0.0f;
    GpuLight light;
    if (LIGHT_TREE_ON) {
        float pt = PARAM(light_tree_pmf);
        count -= PARAM(num_tree_lights);
        if (pick < pt || count == 0u) {
            TreePick tp = light_tree_pick(SCENE_ARGS_ x, rn, MINF(pick / pt, 0.99999994f));
            light = LIGHT(tp.slot);
            tree_pmf = pt * tp.pmf;
            by_tree = true;
        } else {
            pick = MINF((pick - pt) / (1.0f - pt), 0.99999994f);
        }
    }
    if (!by_tree) {
        float scaled = pick * F32(count);
        uint slot = min(U32(scaled), count - 1u);
        light = LIGHT(slot);
        if ((scaled - F32(slot)) >= light.prob) light = LIGHT(light.alias);
    }
    float pmf = by_tree ? tree_pmf : light.pmf;
    uint prim = light.prim;
    if (HAS_FEATURE(FEATURE_PUNCTUAL_LIGHTS) && (prim & LIGHT_PUNCTUAL_BIT) != 0u) {
        ls = sample_punctual(SCENE_ARGS_ prim & LIGHT_INDEX_MASK, x, pmf);
    } else if (HAS_FEATURE(FEATURE_ENVIRONMENT) && prim == LIGHT_ENVIRONMENT) {
        ls = sample_environment(SCENE_ARGS_ u.y, u.z, pmf);
    } else if (HAS_FEATURE(FEATURE_SPHERE_LIGHTS) && (prim & LIGHT_SPHERE_BIT) != 0u) {
        // Sphere: uniform direction in the cone it subtends.
        GpuSphere sph = SPHERE(prim & ~LIGHT_SPHERE_BIT);
        vec3 c = V3(sph.cx, sph.cy, sph.cz);
        vec3 to_c = c - x;
        float r2 = sph.radius * sph.radius;
        float d2 = dot(to_c, to_c);
        if (d2 <= r2) return ls;
        float dc = sqrt(d2);
        float omc = one_minus_cos_cone(r2 / d2);
        vec3 rel = sample_cone(u.y, u.z, omc);
        ls.wi = normalize(frame_to_world(frame_from_normal(DIVF(to_c, dc)), rel));
        // Distance to the near side of the sphere along wi.
        float sin2 = rel.x * rel.x + rel.y * rel.y;
        float ds = dc * rel.z - sqrt(MAXF(0.0f, r2 - d2 * sin2));
        vec3 on = x + ls.wi * ds - c;
        ls.n = DIVF(on, length(on));
        ls.p = c + ls.n * sph.radius;
        ls.p_error = VABS(ls.n * sph.radius) * gamma_bound(5.0f) + VABS(ls.p) * gamma_bound(2.0f);
        GpuMaterial m = MATERIAL(sph.material);
        ls.le = material_emission(m);
        ls.pdf = by_tree ? sphere_cone_pdf(sph, x, pmf)
                         : sphere_light_pdf(SCENE_ARGS_ prim & ~LIGHT_SPHERE_BIT, x, rn);
        ls.valid = ls.pdf > 0.0f;
    } else if ((HAS_FEATURE(FEATURE_TRIANGLE_LIGHTS) || HAS_FEATURE(FEATURE_RECT_LIGHTS)) &&
               (prim & ~LIGHT_INDEX_MASK) == 0u) {
        // Triangle, or the rectangle it is half of: a point by solid angle (else by area);
        // emission from the front, or both faces.
        GpuTriangle tri = TRIANGLE(prim);
        vec3 v0 = tri_v0(tri), v1 = tri_v1(tri), v2 = tri_v2(tri);
        GpuMaterial m = MATERIAL(tri.material);
        bool rect = is_rect_light(m);
        float omega, area;
        vec2 b = V2(0.0f, 0.0f);
        // The uniforms warped toward the receiver's cosine at the corners (by solid angle
        // only); the warp's density divides the sample's value below.
        vec2 uw = V2(u.y, u.z);
        float warp_pdf = 1.0f;
        if (rect) {
            RectLight r = rect_of_triangle(v0, v1, v2);
            omega = rect_solid_angle(SCENE_ARGS_ r, x);
            area = rect_area(r);
            if (cosine_warp_on(SCENE_ARGS_ omega)) {
                vec3 c = r.c - x;
                vec3 q =
                    cosine_warp(uw, V4(cosine_warp_weight(ns, c), cosine_warp_weight(ns, c + r.ex),
                                       cosine_warp_weight(ns, c + r.ey),
                                       cosine_warp_weight(ns, c + r.ex + r.ey)));
                uw = V2(q.x, q.y);
                warp_pdf = q.z;
            }
            vec2 st = sample_rect_light(r, x, omega, uw);
            vec3 ps = r.ex * st.x, pt = r.ey * st.y;
            ls.p = r.c + ps + pt;
            ls.p_error = (VABS(r.c) + VABS(ps) + VABS(pt)) * gamma_bound(6.0f);
        } else {
            omega = triangle_solid_angle(SCENE_ARGS_ v0, v1, v2, x);
            area = triangle_area(tri);
            if (cosine_warp_on(SCENE_ARGS_ omega)) {
                float w1 = cosine_warp_weight(ns, v1 - x);
                vec3 q = cosine_warp(
                    uw, V4(w1, w1, cosine_warp_weight(ns, v0 - x), cosine_warp_weight(ns, v2 - x)));
                uw = V2(q.x, q.y);
                warp_pdf = q.z;
            }
            b = sample_triangle_light(v0, v1, v2, x, omega, uw);
            vec3 p0 = v0 * (1.0f - b.x - b.y), p1 = v1 * b.x, p2 = v2 * b.y;
            ls.p = p0 + p1 + p2;
            ls.p_error = (VABS(p0) + VABS(p1) + VABS(p2)) * gamma_bound(6.0f);
        }
        ls.n = normalize(cross(v1 - v0, v2 - v0));
        vec3 to_l = ls.p - x;
        float dist2 = dot(to_l, to_l);
        ls.wi = to_l * inversesqrt(dist2);
        float cos_l = -dot(ls.n, ls.wi);
        if (cos_l < 0.0f && emits_from_back(m)) cos_l = -cos_l;
        if (cos_l <= 0.0f || dist2 <= 0.0f) return ls;
        ls.le = material_emission(m);
        if (HAS_FEATURE(FEATURE_TEXTURES) && m.tex_emission != NO_TEXTURE && !rect) {
            // Emission texture at the point (the pdf stays the factor's, as for hits; the host
            // pairs no rectangle of a textured emission).
            vec2 uv = V2(0.0f, 0.0f);
            if ((PARAM(scene_flags) & SCENE_VERTEX_DATA) != 0u) {
                GpuTriangleAttributes a = ATTRIBUTES(prim);
                uv = V2(a.u0, a.v0) * (1.0f - b.x - b.y) + V2(a.u1, a.v1) * b.x +
                     V2(a.u2, a.v2) * b.y;
            }
            vec4 t = sample_texture(SCENE_ARGS_ m.tex_emission, uv);
            ls.le = ls.le * V3(t.x, t.y, t.z);
        }
        // (pmf: the pick's probability; a BSDF-sampled hit recomputes it, triangle_pick_pmf.)
        // The pdf stays the unwarped one: the MIS weights of both strategies take it, as a
        // BSDF-sampled hit computes it without the normal at the vertex before (weights that
        // sum to one keep the sum unbiased); the warp's density divides the value alone.
        ls.pdf = triangle_light_pdf(pmf, omega, area, dist2, cos_l);
        ls.le = ls.le * (1.0f / warp_pdf);
        ls.valid = true;
    }
    return ls;
}

// Solid-angle pdf with which next-event estimation would have produced the emitter hit
// `hit` from x (receiver normal rn), for the MIS weight of a BSDF-sampled ray.
MCPT_FN float emitter_hit_pdf(SCENE_PARAMS_ vec3 x, vec3 rn, Ray ray, Hit hit, SurfacePoint s) {
    if (HAS_FEATURE(FEATURE_SPHERE_LIGHTS) && (hit.prim & SPHERE_BIT) != 0u) {
        return sphere_light_pdf(SCENE_ARGS_ hit.prim & ~SPHERE_BIT, x, rn);
    }
    float cos_l = ABSF(dot(s.ng, ray.d));  // the front, or a two-sided emitter's back
    vec3 to_l = s.p - x;
    GpuTriangle tri = TRIANGLE(hit.prim);
    GpuMaterial m = MATERIAL(s.material);
    vec3 v0 = tri_v0(tri), v1 = tri_v1(tri), v2 = tri_v2(tri);
    float omega, area;
    if (is_rect_light(m)) {
        RectLight r = rect_of_triangle(v0, v1, v2);
        omega = rect_solid_angle(SCENE_ARGS_ r, x);
        area = rect_area(r);
    } else {
        omega = triangle_solid_angle(SCENE_ARGS_ v0, v1, v2, x);
        area = triangle_area(tri);
    }
    float pick = triangle_pick_pmf(SCENE_ARGS_ hit.prim, x, rn, m, area);
    return triangle_light_pdf(pick, omega, area, dot(to_l, to_l), cos_l);
}

MCPT_NAMESPACE_END

#endif  // MCPT_GPU_LIGHT_CHOICE_H
