// The path tracer: camera rays, next-event estimation to a light chosen in proportion to its
// power (a point on an emitter, a punctual light, a direction of the environment), BSDF
// sampling, both combined by multiple importance sampling (power heuristic; delta lights
// by NEE alone), Russian roulette; step_slot runs a pixel's samples one bounce per
// iteration (step_slot_walk: with the BVH walked a few node steps at a time). Shared verbatim
// by OpenCL C, GLSL and C++; the light choice and its pdfs are light_choice.h, the hit
// point surface_point.h.
#ifndef MCPT_GPU_INTEGRATOR_H
#define MCPT_GPU_INTEGRATOR_H

#include "bsdf.h"
#include "light_choice.h"  // sample_light, emitter_hit_pdf
#include "sampler.h"
#include "surface_point.h"  // SurfacePoint, surface_at
#include "traverse.h"

MCPT_NAMESPACE_BEGIN

#define SHADOW_EPSILON 1.0e-4f

// How the environment is reached: 0 (always): both strategies combined by MIS. Tests and the
// variance table of docs/lights.md build 1 (next-event estimation alone), 2 (BSDF sampling
// alone), 3 (both unweighted: a biased variant, the negative control) and 4 (both weighted
// 1/2: unbiased, but without MIS's variance bound, its control) through
// BackendOptions::env_strategy (OpenCL: -DMCPT_ENV_STRATEGY; Vulkan: specialization constant
// 6). A constant either way: the compiler folds every branch on it.
#ifndef MCPT_ENV_STRATEGY
#define MCPT_ENV_STRATEGY 0u
#endif

// The C++ build reports every ray trace_path() traces to the thread's RayWork, if one is set
// (cpu_path_work); devices compile the hook out.
#if defined(MCPT_CPP)
inline thread_local RayWork* path_work = nullptr;
#define MCPT_COUNT_RAY(hit) \
    if (path_work) path_work->add(hit)
#else
#define MCPT_COUNT_RAY(hit)
#endif

// Four uniforms of dimension group `group` for `pixel`'s sample `sample_index`: Owen-scrambled
// Sobol points (sampler.h), or independent hashed uniforms (rng.h) in builds that ask for them.
// Group 0 is the camera; bounce d uses groups 2d + 1 (light point, light choice, roulette) and
// 2d + 2 (BSDF direction, lobe choice), each pair of sample dimensions on dimensions 0 and 1.
MCPT_FN vec4 sample4(uint pixel, uint sample_index, uint group, uint seed) {
    if (HAS_FEATURE(FEATURE_INDEPENDENT_SAMPLER)) return rng4(pixel, sample_index, group, seed);
    return sobol4(pixel, sample_index, group, seed);
}

MCPT_FN float quiet_nan() {
    return uint_as_float(0x7fc00000u);
}

MCPT_FN PathResult path_result(vec3 radiance, uint rays) {
    PathResult r;
    r.radiance = radiance;
    r.rays = rays;
    return r;
}

// The pinhole camera's ray through the image-plane point (fx, fy) in [-1, 1]^2, y up.
MCPT_FN Ray camera_ray(SCENE_PARAMS_ float fx, float fy) {
    Ray ray;
    ray.o = V3(PARAM(cam_px), PARAM(cam_py), PARAM(cam_pz));
    ray.d = normalize(V3(PARAM(cam_wx), PARAM(cam_wy), PARAM(cam_wz)) +
                      V3(PARAM(cam_ux), PARAM(cam_uy), PARAM(cam_uz)) * fx +
                      V3(PARAM(cam_vx), PARAM(cam_vy), PARAM(cam_vz)) * fy);
    ray.tmax = MCPT_FLT_MAX;
    return ray;
}

// A path between bounces, and between dispatches: everything the bounce loop carries.
#define PATH_RUNNING 0u
#define PATH_ENDED 1u    // radiance is the sample
#define PATH_INVALID 2u  // a traversal the device cut short: the sample is counted, never added
MCPT_STRUCT(PathState) {
    vec3 o, d;  // the next ray (tmax infinite)
    vec3 beta, radiance, prev_p;
#ifdef MCPT_CARRIED_RECEIVER
    vec2 prev_n;  // the receiver normal at prev_p (light_tree.h: receiver_encode)
#endif
    float eta_scale, prev_pdf;
    uint depth, rays, status;
#ifdef MCPT_CARRIED_MEDIUM
    uint medium;  // absorbing glass the path is inside: its material + 1 (0: none)
#endif
    bool specular;
    uint sample_index, samples_left;  // this sample, and the samples this pixel still owes
#ifdef MCPT_CARRIED_SHADOW
    // One trace site (MCPT_TRACE_SITES = 1): next-event estimation's shadow ray, traced at the
    // path's next step, and what it adds to the radiance if nothing blocks it; never pending
    // between dispatches. (Builds with two sites have none of it: in NVIDIA's OpenCL a larger
    // path, or a pair of structs, went through local memory, 1.2-7x slower.)
    vec3 shadow_o, shadow_d, shadow_contribution;
    float shadow_tmax;
    bool shadow_pending;
#endif
};

// The receiver normal at prev_p, where builds without the light tree carry none (OpenCL: its
// features are known when the source is compiled; GLSL: always, as specialization constants).
#ifdef MCPT_CARRIED_RECEIVER
#define PREV_RECEIVER(st) (st).prev_n
#define SET_PREV_RECEIVER(st, code) (st).prev_n = (code)
#else
#define PREV_RECEIVER(st) NO_RECEIVER
#define SET_PREV_RECEIVER(st, code)
#endif

// The absorbing glass the path is inside (its material + 1; 0: none), where the build has
// volumes.
#ifdef MCPT_CARRIED_MEDIUM
#define PATH_MEDIUM(st) (st).medium
#define SET_PATH_MEDIUM(st, m) (st).medium = (m)
#else
#define PATH_MEDIUM(st) 0u
#define SET_PATH_MEDIUM(st, m)
#endif

// The path waits on a shadow ray (only with one trace site).
#ifdef MCPT_CARRIED_SHADOW
#define SHADOW_PENDING(st) (st).shadow_pending
#else
#define SHADOW_PENDING(st) false
#endif

// No shadow ray pending.
MCPT_FN PathState without_shadow(PathState st) {
#ifdef MCPT_CARRIED_SHADOW
    st.shadow_o = V3S(0.0f);
    st.shadow_d = V3S(0.0f);
    st.shadow_contribution = V3S(0.0f);
    st.shadow_tmax = 0.0f;
    st.shadow_pending = false;
#endif
    return st;
}

// The camera ray of `pixel`'s sample `sample_index` through a jittered point of the pixel.
MCPT_FN PathState start_path(SCENE_PARAMS_ uint pixel, uint sample_index) {
    vec4 u_cam = sample4(pixel, sample_index, 0u, PARAM(seed));
    uint px = pixel % PARAM(width), py = pixel / PARAM(width);
    float fx = DIVF(F32(px) + u_cam.x, F32(PARAM(width))) * 2.0f - 1.0f;
    float fy = 1.0f - DIVF(F32(py) + u_cam.y, F32(PARAM(height))) * 2.0f;
    Ray ray = camera_ray(SCENE_ARGS_ fx, fy);
    PathState st;
    st.o = ray.o;
    st.d = ray.d;
    st.beta = V3S(1.0f);
    st.radiance = V3S(0.0f);
    st.prev_p = ray.o;
    SET_PREV_RECEIVER(st, NO_RECEIVER);
    st.eta_scale = 1.0f;
    st.prev_pdf = 0.0f;
    st.depth = 0u;
    st.rays = 0u;
    st.status = PATH_RUNNING;
    SET_PATH_MEDIUM(st, 0u);  // cameras stand outside every volume
    st.specular = true;
    st.sample_index = sample_index;
    st.samples_left = 1u;
    return without_shadow(st);
}

// Whether light arriving from wi may count at a vertex of geometric normal n (on wo's side)
// and shading normal ns: on the same side of both surfaces (else it would leak through), in
// front unless the material transmits. (shade_vertex writes the same test out.)
MCPT_FN bool light_on_side(GpuMaterial m, vec3 n, vec3 ns, vec3 wi) {
    float cos_s = dot(ns, wi), cos_g = dot(n, wi);
#ifdef MCPT_NEGATIVE_CONTROL_LEAK
    return cos_s > 0.0f;  // tests: a variant that lets light leak
#else
    return is_transmissive(m) ? cos_s * cos_g > 0.0f : cos_s > 0.0f && cos_g > 0.0f;
#endif
}

// Next-event estimation among a few lamps (SCENE_LIGHT_CONTRIBUTION: every light punctual,
// at most LIGHT_CONTRIBUTION_MAX): each lamp's unshadowed contribution at the vertex, the
// BSDF toward it included, and one picked in proportion to it, so the estimate is exact
// wherever the picked lamp is visible. Lamps cannot be hit by BSDF-sampled rays, so no MIS
// weight needs this pmf later.
#define LIGHT_CONTRIBUTION_ON                   \
    (HAS_FEATURE(FEATURE_LIGHT_CONTRIBUTION) && \
     (PARAM(scene_flags) & SCENE_LIGHT_CONTRIBUTION) != 0u)
MCPT_FN LightSample sample_lamp_by_contribution(SCENE_PARAMS_ GpuMaterial m, vec3 x, vec3 n,
                                                vec3 ns, vec3 wo, bool front, float u) {
    LightSample chosen = no_light_sample();
    float total = 0.0f, chosen_w = 0.0f;
    NO_UNROLL
    for (uint i = 0u; i < PARAM(num_lights); ++i) {
        LightSample ls = sample_punctual(SCENE_ARGS_ LIGHT(i).prim & LIGHT_INDEX_MASK, x, 1.0f);
        if (!ls.valid || !light_on_side(m, n, ns, ls.wi)) continue;
        vec3 c = eval_bsdf(m, ns, wo, ls.wi, front).f * ls.le * ABSF(dot(ns, ls.wi));
        float w = c.x + c.y + c.z;
        if (!(w > 0.0f) || is_nonfinite(w)) continue;
        total += w;
        StreamPick p = stream_pick(u, w, total);
        u = p.u;
        if (p.take) {
            chosen = ls;
            chosen_w = w;
#ifdef MCPT_NEGATIVE_CONTROL_CONTRIBUTION_PMF  // tests: the first lamp's pmf 10% off
            if (i == 0u) chosen_w *= 1.1f;
#endif
        }
    }
    if (!chosen.valid) return chosen;
    chosen.pdf = DIVF(chosen_w, total);
    return chosen;
}

// The vertex a path's ray hit: its emission, next-event estimation (the shadow ray traced
// here with two trace sites; with one, left pending in the path with what it adds if nothing
// blocks it), the BSDF sample, Russian roulette. The path comes out ended, or running from
// its next ray. The same sums either way: the light's contribution is added before the next
// vertex's emission.
MCPT_FN PathState shade_vertex(SCENE_PARAMS_ PathState st, Ray ray, Hit hit, uint pixel) {
    uint seed = PARAM(seed);
    float light_scale = PARAM(light_scale);
    uint depth = st.depth;
    // Beer-Lambert along the segment just traced, inside absorbing glass (all of it where the
    // ray escapes: an open volume lets nothing out).
    if (HAS_FEATURE(FEATURE_VOLUME) && PATH_MEDIUM(st) != 0u)
        st.beta *= transmittance(material_sigma(MATERIAL(PATH_MEDIUM(st) - 1u)),
                                 hit.prim == NO_HIT ? MCPT_FLT_MAX : hit.t);
    if (hit.prim == NO_HIT) {
        // The environment, MIS-weighted unless NEE could not have sampled the direction.
        if (HAS_FEATURE(FEATURE_ENVIRONMENT) && PARAM(env_width) > 0u) {
            vec3 le;
            float w = 1.0f;
            if (st.specular) {
                le = env_seen(SCENE_ARGS_ ray.d);  // nothing else samples it: bilinear
            } else {
                vec4 t = env_lookup(SCENE_ARGS_ ray.d);
                le = V3(t.x, t.y, t.z);
                float env_pdf = PARAM(env_pmf) * env_solid_angle_pdf(t, ray.d);
                w = power_heuristic(st.prev_pdf, env_pdf);
                if (MCPT_ENV_STRATEGY == 1u) w = env_pdf > 0.0f ? 0.0f : 1.0f;
                if (MCPT_ENV_STRATEGY == 2u || MCPT_ENV_STRATEGY == 3u) w = 1.0f;
                if (MCPT_ENV_STRATEGY == 4u) w = env_pdf > 0.0f ? 0.5f : 1.0f;
            }
            st.radiance += st.beta * le * (w * light_scale);
        }
        st.status = PATH_ENDED;
        return st;
    }
    SurfacePoint s = surface_at(SCENE_ARGS_ ray, hit);
    GpuMaterial m = MATERIAL(s.material);
    vec4 normal_texel = V4S(0.0f);
    if (HAS_FEATURE(FEATURE_TEXTURES)) {
        TexturedMaterial tm = textured_material(SCENE_ARGS_ m, s.uv);
        m = tm.m;
        normal_texel = tm.normal_texel;
    }
    vec3 wo = -ray.d;
    bool front = dot(s.ng, wo) > 0.0f;
    vec3 n = front ? s.ng : -s.ng;
    // The shading normal on wo's side (interpolated, normal-mapped); the geometric one
    // where it faces away from wo.
    vec3 ns = n;
    if (HAS_FEATURE(FEATURE_SHADING_NORMALS)) {
        vec3 sn = s.ns;
        if (HAS_FEATURE(FEATURE_TEXTURES) && m.tex_normal != NO_TEXTURE)
            sn = normal_mapped(normal_texel, sn, s.dpdu, s.dpdv);
        sn = front ? sn : -sn;
        if (dot(sn, wo) > 0.0f) ns = sn;
    }

    // Emission seen by this ray, MIS-weighted unless NEE could not have sampled it; then the
    // material's kind alone, for its BSDF.
    vec3 le = material_emission(m) * light_scale;
    bool emits = front || emits_from_back(m);
    bool volume = HAS_FEATURE(FEATURE_VOLUME) && (m.type & MAT_VOLUME) != 0u;
    m.type &= MAT_KIND_MASK;
    if (emits && max_component(le) > 0.0f) {
        float w = 1.0f;
        if (!st.specular) {
            vec2 rn_code = PREV_RECEIVER(st);
#ifdef MCPT_NEGATIVE_CONTROL_RECEIVER_MIS  // tests: MIS that forgets the normal (biased)
            rn_code = NO_RECEIVER;
#endif
            w = power_heuristic(
                st.prev_pdf,
                emitter_hit_pdf(SCENE_ARGS_ st.prev_p, receiver_decode(rn_code), ray, hit, s));
        }
        st.radiance += st.beta * le * w;
    }
    if (depth >= PARAM(max_depth)) {
        st.status = PATH_ENDED;
        return st;
    }

    vec4 ua = sample4(pixel, st.sample_index, 2u * depth + 1u, seed);
    vec4 ub = sample4(pixel, st.sample_index, 2u * depth + 2u, seed);

    // The receiver's normal for the light tree: the geometric one on wo's side (no light from
    // below it reaches an opaque surface); none where the material transmits.
    vec2 rn_code = NO_RECEIVER;
#ifndef MCPT_NO_RECEIVER_BOUND  // tests: the tree without it
    if (LIGHT_TREE_ON && !is_transmissive(m)) rn_code = receiver_encode(n);
#endif
    vec3 rn = receiver_decode(rn_code);

    // Next-event estimation at vertices with a smooth lobe.
    if (has_smooth_lobe(m) && PARAM(num_lights) > 0u) {
        LightSample ls;
        if (LIGHT_CONTRIBUTION_ON)
            ls = sample_lamp_by_contribution(SCENE_ARGS_ m, s.p, n, ns, wo, front, ua.z);
        else
            ls = sample_light(SCENE_ARGS_ s.p, rn, ns, V3(ua.z, ua.x, ua.y));
        // The light must lie on the same side of the shading and the geometric surface
        // (else it would leak through), in front unless the material transmits. (Written out
        // here, not light_on_side(): NVIDIA's OpenCL ran the materials scene 7-9% slower so.)
        float cos_s = dot(ns, ls.wi), cos_g = dot(n, ls.wi);
        float cos_x = ABSF(cos_s);
#ifdef MCPT_NEGATIVE_CONTROL_LEAK
        bool side = cos_s > 0.0f;  // tests: a variant that lets light leak
#else
        bool side = is_transmissive(m) ? cos_s * cos_g > 0.0f : cos_s > 0.0f && cos_g > 0.0f;
#endif
        if (ls.valid && side) {
            Ray shadow;
            shadow.o = offset_ray_origin(s.p, s.p_error, s.ng, ls.wi);
            shadow.d = offset_ray_origin(ls.p, ls.p_error, ls.n, -ls.wi) - shadow.o;
            shadow.tmax = 1.0f - SHADOW_EPSILON;
            if ((HAS_FEATURE(FEATURE_PUNCTUAL_LIGHTS) || HAS_FEATURE(FEATURE_ENVIRONMENT)) &&
                ls.at_infinity) {
                shadow.d = ls.wi;
                shadow.tmax = MCPT_FLT_MAX;
            }
            // Two trace sites: the shadow ray now. (Its count and status stay written out
            // here and at the path's ray: one helper for both made NVIDIA's OpenCL 4x slower
            // on the Cornell box.) One: at the path's next step (step_path).
            bool unblocked = true;
            if (MCPT_TRACE_SITES != 1u) {
                Hit blocker = trace_ray(SCENE_ARGS_ shadow, true);
                st.rays += 1u;
                MCPT_COUNT_RAY(blocker);
                if (blocker.status != 0u) {
                    st.status = PATH_INVALID;
                    return st;
                }
                unblocked = blocker.prim == NO_HIT;
            }
            if (unblocked) {
                BsdfEval e = eval_bsdf(m, ns, wo, ls.wi, front);
                float w = ls.delta ? 1.0f : power_heuristic(ls.pdf, e.pdf);
                if (MCPT_ENV_STRATEGY != 0u && ls.at_infinity && !ls.delta)
                    w = MCPT_ENV_STRATEGY == 2u ? 0.0f : (MCPT_ENV_STRATEGY == 4u ? 0.5f : 1.0f);
                vec3 contribution = st.beta * e.f * ls.le * DIVF(light_scale * cos_x * w, ls.pdf);
                // Through absorbing glass: this glass's inside where the light lies there,
                // else the volume the path is in.
                if (HAS_FEATURE(FEATURE_VOLUME)) {
                    uint medium =
                        volume ? (dot(ls.wi, s.ng) < 0.0f ? s.material + 1u : 0u) : PATH_MEDIUM(st);
                    if (medium != 0u)
                        contribution *=
                            transmittance(material_sigma(MATERIAL(medium - 1u)),
                                          ls.at_infinity ? MCPT_FLT_MAX : length(shadow.d));
                }
#ifdef MCPT_CARRIED_SHADOW
                if (MCPT_TRACE_SITES == 1u) {
                    st.shadow_o = shadow.o;
                    st.shadow_d = shadow.d;
                    st.shadow_tmax = shadow.tmax;
                    st.shadow_contribution = contribution;
                    st.shadow_pending = true;
                } else
#endif
                    st.radiance += contribution;
            }
        }
    }

    // Sample the BSDF for the next direction.
    BsdfSample bs = sample_bsdf(m, ns, wo, front, V3(ub.x, ub.y, ub.z));
    // A direction on different sides of the shading and the geometric surface ends the
    // path: light never leaks through the geometry.
#ifndef MCPT_NEGATIVE_CONTROL_LEAK
    if (HAS_FEATURE(FEATURE_SHADING_NORMALS) && dot(bs.wi, n) * dot(bs.wi, ns) <= 0.0f)
        bs.valid = false;
#endif
    if (!bs.valid) {
        st.status = PATH_ENDED;
        return st;
    }
    // Through absorbing glass: into its inside, or out of it.
    if (volume && dot(bs.wi, s.ng) * dot(wo, s.ng) < 0.0f)
        SET_PATH_MEDIUM(st, front ? s.material + 1u : 0u);
    st.beta = st.beta * bs.weight;
    st.eta_scale *= bs.eta2;
    st.specular = bs.specular;
    st.prev_pdf = bs.pdf;
    st.prev_p = s.p;
    SET_PREV_RECEIVER(st, rn_code);
    st.o = offset_ray_origin(s.p, s.p_error, s.ng, bs.wi);
    st.d = bs.wi;
    st.depth = depth + 1u;

    // Russian roulette on the square root of the throughput (with the IOR scaling undone),
    // as Cycles does: paths live longer than with the throughput itself, 14% less variance
    // per sample for 10% more time on the Cornell box (docs/sampling.md). Tests build a
    // biased variant that forgets to reweight survivors (MCPT_NEGATIVE_CONTROL_RR).
    if (depth + 1u >= PARAM(rr_depth)) {
        float survive = MINF(1.0f, sqrt(max_component(st.beta * st.eta_scale)));
        if (ua.w >= survive) {
            st.status = PATH_ENDED;
            return st;
        }
#ifndef MCPT_NEGATIVE_CONTROL_RR
        st.beta = DIVF(st.beta, survive);
#endif
    }
    return st;
}

// A carried shadow ray's hit: the light's contribution when nothing blocks it (before the
// next vertex's emission, as with two sites). (A macro: step_path and step_slot_walk.)
#define SHADOW_RAY_ENDED(ST, HIT)   \
    (ST).shadow_pending = false;    \
    if ((HIT).status != 0u)         \
        (ST).status = PATH_INVALID; \
    else if ((HIT).prim == NO_HIT)  \
        (ST).radiance += (ST).shadow_contribution;

// One step of a path: the ray to its next vertex and what follows from it. With one trace
// site (MCPT_TRACE_SITES, scene_access.h), a pending shadow ray goes first, from the same
// call: the kernel's only traversal (NVIDIA's Vulkan compiler inlines each call, and two
// overflowed its instruction cache beside the texture code).
MCPT_FN PathState step_path(SCENE_PARAMS_ PathState st, uint pixel) {
    Ray ray;
    ray.o = st.o;
    ray.d = st.d;
    ray.tmax = MCPT_FLT_MAX;
    bool shadow = false;
#ifdef MCPT_CARRIED_SHADOW
    shadow = MCPT_TRACE_SITES == 1u && st.shadow_pending;
    if (shadow) {
        ray.o = st.shadow_o;
        ray.d = st.shadow_d;
        ray.tmax = st.shadow_tmax;
    }
#endif
    Hit hit = trace_ray(SCENE_ARGS_ ray, shadow);
    st.rays += 1u;
    MCPT_COUNT_RAY(hit);
#ifdef MCPT_CARRIED_SHADOW
    if (shadow) {
        SHADOW_RAY_ENDED(st, hit)
        return st;
    }
#endif
    if (hit.status != 0u) {
        st.status = PATH_INVALID;
        return st;
    }
    return shade_vertex(SCENE_ARGS_ st, ray, hit, pixel);
}

// One path's radiance estimate for `pixel`, sample `sample_index`, traced to its end (the
// C++ build's oracle; devices run the same functions through step_slot()).
MCPT_FN PathResult trace_path(SCENE_PARAMS_ uint pixel, uint sample_index) {
    PathState st = start_path(SCENE_ARGS_ pixel, sample_index);
    while (st.status == PATH_RUNNING || SHADOW_PENDING(st)) st = step_path(SCENE_ARGS_ st, pixel);
    if (st.status != PATH_ENDED) return path_result(V3S(quiet_nan()), st.rays);
    return path_result(st.radiance, st.rays);
}

// Per-pixel sums of one dispatch: radiance, squared radiance, and sample counts.
MCPT_STRUCT(PixelSums) {
    vec4 sum;     // rgb: sum of finite samples; w: number of non-finite samples
    vec4 sum_sq;  // rgb: sum of squares; w: number of rays traced
};

// What one dispatch did for one pixel's slot: the path state to keep, the pixel's new sums.
MCPT_STRUCT(SlotStep) {
    PathState st;
    PixelSums sums;
};

// One dispatch's work for the slot of `pixel`: continues its path within the bounce budget;
// each path that ends adds its sample to the pixel's sums (non-finite ones counted, never
// added) and starts the pixel's next sample while the pixel owes samples. Samples are added
// one by one in sample order onto the sums so far, so the float sums do not depend on how the
// samples were split into dispatches (the reproducible mode relies on it). One loop of one
// bounce each: a lane whose path ended starts its next sample in the next iteration instead
// of waiting for the longest path of its SIMD group or warp (path regeneration).
// Node steps a ray's walk takes before the lanes whose rays ended shade (step_slot_walk; 0:
// off). OpenCL: -DMCPT_WALK_STEPS; Vulkan: specialization constant 8 (scene_access.h).
#ifndef MCPT_WALK_STEPS
#define MCPT_WALK_STEPS 0u
#endif

// A sample that ended adds to the pixel's sums (non-finite ones counted, never added), and
// the pixel's next sample starts if it owes one. (A macro: step_slot and step_slot_walk.)
#define END_SAMPLE(ST, SUMS, PIXEL)                                                           \
    {                                                                                         \
        vec3 l = (ST).status == PATH_ENDED ? (ST).radiance : V3S(quiet_nan());                \
        /* Tests: poison every 4th sample of pixel 0 (NaN) and of pixel 1 (+Inf). */          \
        if (HAS_FEATURE(FEATURE_TEST_NAN) && (PIXEL) <= 1u && ((ST).sample_index & 3u) == 0u) \
            l.x = (PIXEL) == 0u ? quiet_nan() : uint_as_float(0x7f800000u);                   \
        (SUMS).sum_sq.w += F32((ST).rays);                                                    \
        if (is_nonfinite3(l)) {                                                               \
            (SUMS).sum.w += 1.0f;                                                             \
        } else {                                                                              \
            (SUMS).sum = (SUMS).sum + V4(l.x, l.y, l.z, 0.0f);                                \
            (SUMS).sum_sq = (SUMS).sum_sq + V4(l.x * l.x, l.y * l.y, l.z * l.z, 0.0f);        \
        }                                                                                     \
        uint left = (ST).samples_left - 1u;                                                   \
        uint next = (ST).sample_index + 1u;                                                   \
        (ST) = start_path(SCENE_ARGS_ PIXEL, next);                                           \
        (ST).samples_left = left;                                                             \
    }

#if defined(MCPT_CARRIED_SHADOW) && !defined(MCPT_RAY_QUERY) && !defined(MCPT_RAY_PIPELINE)
// step_slot with the BVH walked a few node steps at a time (MCPT_WALK_STEPS): a lane whose
// ray ended shades its vertex and starts its next ray while the others go on walking, so a
// GPU warp waits at most MCPT_WALK_STEPS node steps for its longest ray instead of the whole
// ray (issue 64; docs/traversal.md). Every ray (the shadow rays too: one trace site) goes
// through the one walk below; each path's rays, hits and sums are step_slot's, bit for bit.
// Scenes with a BVH.
MCPT_FN SlotStep step_slot_walk(SCENE_PARAMS_ PathState st, uint pixel, PixelSums sums) {
    SlotStep step;
    step.sums = sums;
    uint budget = PARAM(bounce_budget);
    bool masks = HAS_FEATURE(FEATURE_ALPHA_MASK) && (PARAM(scene_flags) & SCENE_ALPHA_MASK) != 0u;
    uvec2 stack[KD_STACK_SIZE];
    // The lane's ray, and the part of it walked now: past the cut-outs met so far (t_base
    // along the ray, the last one skipped), as trace_ray takes them.
    Ray ray;
    ray.o = V3S(0.0f);
    ray.d = V3S(1.0f);
    ray.tmax = 0.0f;
    Ray seg = ray;
    float t_base = 0.0f;
    uint skip = NO_HIT, cutouts = 0u;
    bool shadow = false;
    Hit hit = no_hit(0.0f);
    WoopRay wr = woop_setup(ray.d);
    BvhWalk w = bvh_walk_begin(ray.d);
    w.done = true;
    bool in_ray = false, walk_from_root = false;
    while (true) {
        // The lane's next ray: a pending shadow ray, else the path's, while it owes samples.
        if (!in_ray) {
            if (!SHADOW_PENDING(st) && !(st.samples_left > 0u && budget > 0u)) break;
            shadow = st.shadow_pending;
            if (shadow) {
                ray.o = st.shadow_o;
                ray.d = st.shadow_d;
                ray.tmax = st.shadow_tmax;
            } else {
                budget -= 1u;
                ray.o = st.o;
                ray.d = st.d;
                ray.tmax = MCPT_FLT_MAX;
            }
            seg = ray;
            t_base = 0.0f;
            skip = NO_HIT;
            cutouts = 0u;
            in_ray = walk_from_root = true;
        }
        // Spheres first, one by one (trace_opaque), then the walk from the root. With
        // cut-outs, the nearest hit even for shadow rays (trace_ray).
        bool any_hit = shadow && !masks;
        if (walk_from_root) {
            hit = sphere_hit(SCENE_ARGS_ seg, any_hit);
            wr = woop_setup(seg.d);
            w = bvh_walk_begin(seg.d);
            w.done = (any_hit && hit.prim != NO_HIT) || PARAM(num_triangles) == 0u;
            walk_from_root = false;
        }
        // A few node steps of the walk.
#ifdef MCPT_NEGATIVE_CONTROL_WALK
        w.sp = 0u;  // tests: a walk that loses its stack each time it pauses
#endif
        // Rolled: N copies of the iteration would crowd the instruction cache (as two trace
        // sites did on NVIDIA, and the child-box test's halves unrolled).
        NO_UNROLL
        for (uint k = 0u; k < MCPT_WALK_STEPS && !w.done; ++k)
            BVH_WALK_ITERATION(w, stack, seg, wr, any_hit, skip, hit)
        if (!w.done) continue;
        // Cut out where it was hit: walk on from the hit, past that triangle (trace_ray).
        if (masks && hit.prim != NO_HIT && hit.status == 0u && (hit.prim & SPHERE_BIT) == 0u &&
            !opaque_at(SCENE_ARGS_ TRIANGLE(hit.prim).material, hit.prim, hit.b1, hit.b2)) {
            cutouts += 1u;
            if (cutouts < MAX_CUTOUTS) {
                seg.o = seg.o + seg.d * hit.t;
                seg.tmax -= hit.t;
                t_base += hit.t;
                skip = hit.prim;
                walk_from_root = true;
                continue;
            }
            hit = no_hit(ray.tmax);
            hit.status = TRACE_INCOMPLETE;
        } else {
            hit.t += t_base;  // + 0 without cut-outs: the same bits
        }
        // The ray's hit: as step_path takes it.
        in_ray = false;
        st.rays += 1u;
        if (shadow) {
            SHADOW_RAY_ENDED(st, hit)
        } else if (hit.status != 0u) {
            st.status = PATH_INVALID;
        } else {
            st = shade_vertex(SCENE_ARGS_ st, ray, hit, pixel);
        }
        if (st.status == PATH_RUNNING || SHADOW_PENDING(st)) continue;
        END_SAMPLE(st, step.sums, pixel)
    }
    step.st = st;
    return step;
}
#define WALK_ON                                                                    \
    (MCPT_WALK_STEPS > 0u && MCPT_TRACE_SITES == 1u && HAS_FEATURE(FEATURE_BVH) && \
     (PARAM(scene_flags) & SCENE_BVH) != 0u)
#endif

MCPT_FN SlotStep step_slot(SCENE_PARAMS_ PathState st, uint pixel, PixelSums sums) {
#ifdef WALK_ON
    if (WALK_ON) return step_slot_walk(SCENE_ARGS_ st, pixel, sums);
#endif
    SlotStep step;
    step.sums = sums;
    uint budget = PARAM(bounce_budget);
    // A bounce's shadow ray is traced before the dispatch ends (the state kept between
    // dispatches holds none).
    while (SHADOW_PENDING(st) || (st.samples_left > 0u && budget > 0u)) {
        if (!SHADOW_PENDING(st)) budget -= 1u;
        st = step_path(SCENE_ARGS_ st, pixel);
        if (st.status == PATH_RUNNING || SHADOW_PENDING(st)) continue;
        END_SAMPLE(st, step.sums, pixel)
    }
    step.st = st;
    return step;
}

// Where `pixel`'s sums and path state lie in the accumulation buffer, in vec4s, the vec4
// whose first word is the pending flag, and the word of the pixel's sample plan (layout in
// shared_types.h): the sums of every pixel, or of the window's pixels from state_base when
// accum_window is set.
MCPT_STRUCT(AccumPlace) {
    uint sum, state, pending, plan;
};

MCPT_FN AccumPlace accum_place(SCENE_PARAMS_ uint pixel) {
    bool window = PARAM(accum_window) != 0u;
    uint sum_pixels = window ? PARAM(state_slots) : PARAM(width) * PARAM(height);
    AccumPlace at;
    at.sum = ACCUM_VEC4_PER_PIXEL * (pixel - (window ? PARAM(state_base) : 0u));
    at.state = ACCUM_VEC4_PER_PIXEL * sum_pixels + PATH_STATE_VEC4 * (pixel - PARAM(state_base));
    at.pending = ACCUM_VEC4_PER_PIXEL * sum_pixels + PATH_STATE_VEC4 * PARAM(state_slots);
    at.plan = 4u * (at.pending + 1u) + PLAN_WORDS_PER_SLOT * (pixel - PARAM(state_base));
    return at;
}

// Path state in storage: PATH_STATE_VEC4 vec4 per slot (shared_types.h).
MCPT_STRUCT(PackedState) {
    vec4 a, b, c, d, e, f;
};

MCPT_FN PackedState pack_state(PathState st) {
    PackedState p;
    p.a = V4(st.o.x, st.o.y, st.o.z, st.eta_scale);
    p.b = V4(st.d.x, st.d.y, st.d.z, st.prev_pdf);
    p.c = V4(st.beta.x, st.beta.y, st.beta.z, uint_as_float(st.depth));
    p.d = V4(st.radiance.x, st.radiance.y, st.radiance.z, uint_as_float(st.rays));
    p.e = V4(st.prev_p.x, st.prev_p.y, st.prev_p.z,
             uint_as_float(st.status | (st.specular ? 4u : 0u) | (PATH_MEDIUM(st) << 3u)));
    vec2 prev_n = PREV_RECEIVER(st);
    p.f = V4(uint_as_float(st.sample_index), uint_as_float(st.samples_left), prev_n.x, prev_n.y);
    return p;
}

MCPT_FN PathState unpack_state(PackedState p) {
    PathState st;
    st.o = V3(p.a.x, p.a.y, p.a.z);
    st.eta_scale = p.a.w;
    st.d = V3(p.b.x, p.b.y, p.b.z);
    st.prev_pdf = p.b.w;
    st.beta = V3(p.c.x, p.c.y, p.c.z);
    st.depth = float_as_uint(p.c.w);
    st.radiance = V3(p.d.x, p.d.y, p.d.z);
    st.rays = float_as_uint(p.d.w);
    st.prev_p = V3(p.e.x, p.e.y, p.e.z);
    uint flags = float_as_uint(p.e.w);
    st.status = flags & 3u;
    st.specular = (flags & 4u) != 0u;
    SET_PATH_MEDIUM(st, flags >> 3u);
    st.sample_index = float_as_uint(p.f.x);
    st.samples_left = float_as_uint(p.f.y);
    SET_PREV_RECEIVER(st, V2(p.f.z, p.f.w));
    return without_shadow(st);
}

MCPT_NAMESPACE_END

#endif  // MCPT_GPU_INTEGRATOR_H
