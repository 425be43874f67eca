// The path tracer: camera rays, next-event estimation to a point on an emitter chosen in
// proportion to its power, BSDF sampling, both combined by multiple importance sampling
// (power heuristic), Russian roulette. Shared verbatim by OpenCL C, GLSL and C++.
#ifndef MCPT_GPU_INTEGRATOR_H
#define MCPT_GPU_INTEGRATOR_H

#include "bsdf.h"
#include "rng.h"
#include "traverse.h"

MCPT_NAMESPACE_BEGIN

#define SHADOW_EPSILON 1.0e-4f

// The C++ build reports every ray trace_path() traces to the thread's RayWork, if one is set
// (cpu_path_work); devices compile the hook out.
#if defined(MCPT_CPP)
inline thread_local RayWork* path_work = nullptr;
#define MCPT_COUNT_RAY(hit) \
    if (path_work) path_work->add(hit)
#else
#define MCPT_COUNT_RAY(hit)
#endif

MCPT_FN float quiet_nan() { return uint_as_float(0x7fc00000u); }

// A hit point with its rounding-error bound and geometric normal (front side / outside).
MCPT_STRUCT(SurfacePoint) {
    vec3 p;
    vec3 p_error;
    vec3 ng;
    uint material;
};

MCPT_FN SurfacePoint surface_at(SCENE_PARAMS_ Ray ray, Hit hit) {
    SurfacePoint s;
    if (HAS_FEATURE(FEATURE_SPHERES) && (hit.prim & SPHERE_BIT) != 0u) {
        // Sphere: reproject onto the surface, error bound from pbrt-v4.
        GpuSphere sph = spheres[hit.prim & ~SPHERE_BIT];
        vec3 c = V3(sph.cx, sph.cy, sph.cz);
        vec3 rel = ray.o + ray.d * hit.t - c;
        rel = rel * (sph.radius / length(rel));
        s.p = c + rel;
        s.p_error = VABS(rel) * gamma_bound(5.0f) + VABS(s.p) * gamma_bound(2.0f);
        s.ng = rel / sph.radius;
        s.material = sph.material;
    } else {
        // Triangle: barycentric interpolation, error bound from pbrt-v4.
        GpuTriangle tri = TRIANGLE(hit.prim);
        vec3 v0 = tri_v0(tri), v1 = tri_v1(tri), v2 = tri_v2(tri);
        float b0 = 1.0f - hit.b1 - hit.b2;
        vec3 p0 = v0 * b0, p1 = v1 * hit.b1, p2 = v2 * hit.b2;
        s.p = p0 + p1 + p2;
        s.p_error = (VABS(p0) + VABS(p1) + VABS(p2)) * gamma_bound(7.0f);
        s.ng = normalize(cross(v1 - v0, v2 - v0));
        s.material = tri.material;
    }
    return s;
}

MCPT_STRUCT(LightSample) {
    vec3 wi;       // unit direction from the shading point to the light point
    vec3 p;        // point on the light
    vec3 p_error;  // its rounding-error bound
    vec3 n;        // light normal at p (emitting side)
    vec3 le;       // emitted radiance toward the shading point
    float pdf;     // solid-angle pdf of choosing this direction
    bool valid;
};

// Probability per unit area of a point on an emitter: power-proportional light choice
// (area * mean(Le) / total) times uniform area sampling.
MCPT_FN float emitter_area_pdf(SCENE_PARAMS_ GpuMaterial m) {
    return mean_component(material_emission(m)) / PARAM(light_power_total);
}

// Solid-angle pdf that next-event estimation samples a sphere light from x (cone sampling).
MCPT_FN float sphere_light_pdf(SCENE_PARAMS_ GpuSphere sph, vec3 x) {
    vec3 to_c = V3(sph.cx, sph.cy, sph.cz) - x;
    float r2 = sph.radius * sph.radius;
    float d2 = dot(to_c, to_c);
    if (d2 <= r2) return 0.0f;  // inside: never sampled from here
    float pmf = 4.0f * MCPT_PI * r2 * emitter_area_pdf(SCENE_ARGS_ MATERIAL(sph.material));
    return pmf / (2.0f * MCPT_PI * one_minus_cos_cone(r2 / d2));
}

// Choose an emitter by power (alias table), then a point on it seen from x. u: 3 uniforms.
MCPT_FN LightSample sample_light(SCENE_PARAMS_ vec3 x, vec3 u) {
    LightSample ls;
    ls.valid = false;
    ls.wi = V3S(0.0f);
    ls.p = V3S(0.0f);
    ls.p_error = V3S(0.0f);
    ls.n = V3S(0.0f);
    ls.le = V3S(0.0f);
    ls.pdf = 0.0f;
    // Alias table lookup.
    uint count = PARAM(num_lights);
    float scaled = u.x * F32(count);
    uint slot = min(U32(scaled), count - 1u);
    GpuLight light = LIGHT(slot);
    uint prim = (scaled - F32(slot)) < light.prob ? light.prim : LIGHT(light.alias).prim;
    if (HAS_FEATURE(FEATURE_SPHERE_LIGHTS) && (prim & LIGHT_SPHERE_BIT) != 0u) {
        // Sphere: uniform direction in the cone it subtends.
        GpuSphere sph = spheres[prim & ~LIGHT_SPHERE_BIT];
        vec3 c = V3(sph.cx, sph.cy, sph.cz);
        vec3 to_c = c - x;
        float r2 = sph.radius * sph.radius;
        float d2 = dot(to_c, to_c);
        if (d2 <= r2) return ls;
        float dc = sqrt(d2);
        float omc = one_minus_cos_cone(r2 / d2);
        vec3 rel = sample_cone(u.y, u.z, omc);
        ls.wi = normalize(frame_to_world(frame_from_normal(to_c / dc), rel));
        // Distance to the near side of the sphere along wi.
        float sin2 = rel.x * rel.x + rel.y * rel.y;
        float ds = dc * rel.z - sqrt(MAXF(0.0f, r2 - d2 * sin2));
        vec3 on = x + ls.wi * ds - c;
        ls.n = on / length(on);
        ls.p = c + ls.n * sph.radius;
        ls.p_error = VABS(ls.n * sph.radius) * gamma_bound(5.0f) + VABS(ls.p) * gamma_bound(2.0f);
        GpuMaterial m = MATERIAL(sph.material);
        ls.le = material_emission(m);
        ls.pdf = sphere_light_pdf(SCENE_ARGS_ sph, x);
        ls.valid = ls.pdf > 0.0f;
    } else if (HAS_FEATURE(FEATURE_TRIANGLE_LIGHTS) && (prim & LIGHT_SPHERE_BIT) == 0u) {
        // Triangle: uniform point, one-sided emission.
        GpuTriangle tri = TRIANGLE(prim);
        vec3 v0 = tri_v0(tri), v1 = tri_v1(tri), v2 = tri_v2(tri);
        vec2 b = sample_triangle_barycentrics(u.y, u.z);
        float b0 = 1.0f - b.x - b.y;
        vec3 p0 = v0 * b0, p1 = v1 * b.x, p2 = v2 * b.y;
        ls.p = p0 + p1 + p2;
        ls.p_error = (VABS(p0) + VABS(p1) + VABS(p2)) * gamma_bound(6.0f);
        ls.n = normalize(cross(v1 - v0, v2 - v0));
        vec3 to_l = ls.p - x;
        float dist2 = dot(to_l, to_l);
        ls.wi = to_l * inversesqrt(dist2);
        float cos_l = -dot(ls.n, ls.wi);
        if (cos_l <= 0.0f || dist2 <= 0.0f) return ls;
        GpuMaterial m = MATERIAL(tri.material);
        ls.le = material_emission(m);
        ls.pdf = emitter_area_pdf(SCENE_ARGS_ m) * dist2 / cos_l;
        ls.valid = true;
    }
    return ls;
}

// Solid-angle pdf with which next-event estimation would have produced the emitter hit
// `hit` from x, for the MIS weight of a BSDF-sampled ray.
MCPT_FN float emitter_hit_pdf(SCENE_PARAMS_ vec3 x, Ray ray, Hit hit, SurfacePoint s) {
    if (HAS_FEATURE(FEATURE_SPHERE_LIGHTS) && (hit.prim & SPHERE_BIT) != 0u) {
        return sphere_light_pdf(SCENE_ARGS_ spheres[hit.prim & ~SPHERE_BIT], x);
    }
    float cos_l = -dot(s.ng, ray.d);
    vec3 to_l = s.p - x;
    return emitter_area_pdf(SCENE_ARGS_ MATERIAL(s.material)) * dot(to_l, to_l) / cos_l;
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

// One path's radiance estimate for `pixel`, sample `sample_index`.
MCPT_FN PathResult trace_path(SCENE_PARAMS_ uint pixel, uint sample_index) {
    uint seed = PARAM(seed);
    float light_scale = PARAM(light_scale);
    // Camera ray through a jittered point of the pixel.
    vec4 u_cam = rng4(pixel, sample_index, 0u, seed);
    uint px = pixel % PARAM(width), py = pixel / PARAM(width);
    float fx = (F32(px) + u_cam.x) / F32(PARAM(width)) * 2.0f - 1.0f;
    float fy = 1.0f - (F32(py) + u_cam.y) / F32(PARAM(height)) * 2.0f;
    Ray ray = camera_ray(SCENE_ARGS_ fx, fy);

    vec3 radiance = V3S(0.0f);
    vec3 beta = V3S(1.0f);
    float eta_scale = 1.0f;
    bool specular = true;
    float prev_pdf = 0.0f;
    vec3 prev_p = ray.o;
    uint rays = 0u;
    bool ended = false;  // set at every real exit of the loop (see TRACE_INCOMPLETE)
    for (uint depth = 0u;; ++depth) {
        // Find the next vertex.
        Hit hit = trace_ray(SCENE_ARGS_ ray, false);
        rays += 1u;
        MCPT_COUNT_RAY(hit);
        if (hit.status != 0u) return path_result(V3S(quiet_nan()), rays);
        if (hit.prim == NO_HIT) {
            ended = true;
            break;
        }
        SurfacePoint s = surface_at(SCENE_ARGS_ ray, hit);
        GpuMaterial m = MATERIAL(s.material);
        vec3 wo = -ray.d;
        bool front = dot(s.ng, wo) > 0.0f;
        vec3 n = front ? s.ng : -s.ng;

        // Emission seen by this ray, MIS-weighted unless NEE could not have sampled it.
        vec3 le = material_emission(m) * light_scale;
        if (front && max_component(le) > 0.0f) {
            float w = 1.0f;
            if (!specular) {
                w = power_heuristic(prev_pdf, emitter_hit_pdf(SCENE_ARGS_ prev_p, ray, hit, s));
            }
            radiance += beta * le * w;
        }
        if (depth >= PARAM(max_depth)) {
            ended = true;
            break;
        }

        vec4 ua = rng4(pixel, sample_index, 2u * depth + 1u, seed);
        vec4 ub = rng4(pixel, sample_index, 2u * depth + 2u, seed);

        // Next-event estimation at diffuse vertices.
        if (HAS_FEATURE(FEATURE_DIFFUSE) && m.type == MAT_DIFFUSE && PARAM(num_lights) > 0u) {
            LightSample ls = sample_light(SCENE_ARGS_ s.p, V3(ua.x, ua.y, ua.z));
            float cos_x = dot(n, ls.wi);
            if (ls.valid && cos_x > 0.0f) {
                Ray shadow;
                shadow.o = offset_ray_origin(s.p, s.p_error, s.ng, ls.wi);
                shadow.d = offset_ray_origin(ls.p, ls.p_error, ls.n, -ls.wi) - shadow.o;
                shadow.tmax = 1.0f - SHADOW_EPSILON;
                Hit blocker = trace_ray(SCENE_ARGS_ shadow, true);
                rays += 1u;
                MCPT_COUNT_RAY(blocker);
                if (blocker.status != 0u) return path_result(V3S(quiet_nan()), rays);
                if (blocker.prim == NO_HIT) {
                    float w = power_heuristic(ls.pdf, diffuse_pdf(n, ls.wi));
                    radiance += beta * diffuse_eval(m, n, ls.wi) * ls.le *
                                (light_scale * cos_x * w / ls.pdf);
                }
            }
        }

        // Sample the BSDF for the next direction.
        BsdfSample bs = sample_bsdf(m, n, wo, front, V3(ub.x, ub.y, ub.z));
        if (!bs.valid) {
            ended = true;
            break;
        }
        beta = beta * bs.weight;
        eta_scale *= bs.eta2;
        specular = bs.specular;
        prev_pdf = bs.pdf;
        prev_p = s.p;
        ray.o = offset_ray_origin(s.p, s.p_error, s.ng, bs.wi);
        ray.d = bs.wi;
        ray.tmax = MCPT_FLT_MAX;

        // Russian roulette on the throughput (with the IOR scaling undone). Tests build a biased
        // variant that forgets to reweight survivors (MCPT_NEGATIVE_CONTROL_RR).
        if (depth + 1u >= PARAM(rr_depth)) {
            float survive = MINF(1.0f, max_component(beta * eta_scale));
            if (ua.w >= survive) {
                ended = true;
                break;
            }
#ifndef MCPT_NEGATIVE_CONTROL_RR
            beta = beta / survive;
#endif
        }
    }
    // A loop the device cut short: an invalid sample, counted and left out like a NaN.
    if (!ended) return path_result(V3S(quiet_nan()), rays);
    return path_result(radiance, rays);
}

// Per-pixel sums of one dispatch: radiance, squared radiance, and sample counts.
MCPT_STRUCT(PixelSums) {
    vec4 sum;    // rgb: sum of finite samples; w: number of non-finite samples
    vec4 sum_sq; // rgb: sum of squares; w: number of rays traced
};

MCPT_FN PixelSums render_pixel(SCENE_PARAMS_ uint pixel) {
    PixelSums acc;
    acc.sum = V4S(0.0f);
    acc.sum_sq = V4S(0.0f);
    uint i = 0u;
    for (; i < PARAM(samples_per_dispatch); ++i) {
        PathResult r = trace_path(SCENE_ARGS_ pixel, PARAM(sample_offset) + i);
        vec3 l = r.radiance;
        // Tests: poison every 4th sample of pixel 0 (NaN) and of pixel 1 (+Inf).
        if (HAS_FEATURE(FEATURE_TEST_NAN) && pixel <= 1u && ((PARAM(sample_offset) + i) & 3u) == 0u)
            l.x = pixel == 0u ? quiet_nan() : uint_as_float(0x7f800000u);
        acc.sum_sq.w += F32(r.rays);
        // Non-finite samples are counted, never added.
        if (is_nonfinite3(l)) {
            acc.sum.w += 1.0f;
        } else {
            acc.sum = acc.sum + V4(l.x, l.y, l.z, 0.0f);
            acc.sum_sq = acc.sum_sq + V4(l.x * l.x, l.y * l.y, l.z * l.z, 0.0f);
        }
    }
    // Samples a device loop limit never ran count as invalid too.
    if (i < PARAM(samples_per_dispatch)) acc.sum.w += F32(PARAM(samples_per_dispatch) - i);
    return acc;
}

MCPT_NAMESPACE_END

#endif  // MCPT_GPU_INTEGRATOR_H
