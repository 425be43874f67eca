// Ray-primitive tests: watertight ray-triangle (Woop, Benthin & Wald, JCGT 2013), a
// precision-aware ray-sphere test (Haines et al., Ray Tracing Gems ch. 7), a NaN-tolerant
// slab test, and error-bounded ray origins (pbrt-v4) instead of fixed epsilons.
#ifndef MCPT_GPU_INTERSECT_H
#define MCPT_GPU_INTERSECT_H

#include "ray_types.h"
#include "sampling.h"
#include "shared_types.h"

MCPT_NAMESPACE_BEGIN

// Per-ray constants of the watertight test: the axis of largest |d| becomes z, the shear
// maps d onto +z. kx/ky are swapped when d.z < 0 to keep the winding.
MCPT_STRUCT(WoopRay) {
    uint kx, ky, kz;
    float sx, sy, sz;
};

MCPT_FN WoopRay woop_setup(vec3 d) {
    vec3 ad = VABS(d);
    WoopRay w;
    w.kz = (ad.x > ad.y) ? (ad.x > ad.z ? 0u : 2u) : (ad.y > ad.z ? 1u : 2u);
    w.kx = w.kz == 2u ? 0u : w.kz + 1u;
    w.ky = w.kx == 2u ? 0u : w.kx + 1u;
    float dz = vec3_at(d, w.kz);
    if (dz < 0.0f) {
        uint tmp = w.kx;
        w.kx = w.ky;
        w.ky = tmp;
    }
    w.sx = vec3_at(d, w.kx) / dz;
    w.sy = vec3_at(d, w.ky) / dz;
    w.sz = 1.0f / dz;
    return w;
}

MCPT_STRUCT(TriHit) {
    float t;
    float b0, b1, b2;  // barycentrics of v0, v1, v2
    bool hit;
};

MCPT_FN vec3 tri_v0(GpuTriangle tri) { return V3(tri.v0x, tri.v0y, tri.v0z); }
MCPT_FN vec3 tri_v1(GpuTriangle tri) { return V3(tri.v1x, tri.v1y, tri.v1z); }
MCPT_FN vec3 tri_v2(GpuTriangle tri) { return V3(tri.v2x, tri.v2y, tri.v2z); }

#if defined(MCPT_OPENCL)
#pragma OPENCL FP_CONTRACT OFF
#endif
// Watertight ray-triangle test; hits with 0 < t < tmax. A ray through a shared edge or
// vertex hits at least one of the triangles that share it.
MCPT_FN TriHit intersect_triangle(Ray ray, WoopRay w, GpuTriangle tri) {
    TriHit h;
    h.hit = false;
    h.t = 0.0f;
    h.b0 = 0.0f;
    h.b1 = 0.0f;
    h.b2 = 0.0f;
    // Vertices relative to the ray origin.
    vec3 a = tri_v0(tri) - ray.o;
    vec3 b = tri_v1(tri) - ray.o;
    vec3 c = tri_v2(tri) - ray.o;
    float az = vec3_at(a, w.kz), bz = vec3_at(b, w.kz), cz = vec3_at(c, w.kz);
    // Shear and scale into ray space (exactly as written, so every call site agrees).
    MCPT_PRECISE float ax = vec3_at(a, w.kx) - w.sx * az, ay = vec3_at(a, w.ky) - w.sy * az;
    MCPT_PRECISE float bx = vec3_at(b, w.kx) - w.sx * bz, by = vec3_at(b, w.ky) - w.sy * bz;
    MCPT_PRECISE float cx = vec3_at(c, w.kx) - w.sx * cz, cy = vec3_at(c, w.ky) - w.sy * cz;
    // Scaled barycentrics from 2D edge functions, rounded exactly as written: a shared edge
    // must give its two triangles values of opposite sign, which a fused multiply-add breaks.
    MCPT_PRECISE float u = cx * by - cy * bx;
    MCPT_PRECISE float v = ax * cy - ay * cx;
    MCPT_PRECISE float wv = bx * ay - by * ax;
    if ((u < 0.0f || v < 0.0f || wv < 0.0f) && (u > 0.0f || v > 0.0f || wv > 0.0f)) return h;
    float det = u + v + wv;
    if (det == 0.0f) return h;
    // Scaled hit distance, compared without a division.
    float t_scaled = w.sz * (u * az + v * bz + wv * cz);
    if (det < 0.0f && (t_scaled >= 0.0f || t_scaled < ray.tmax * det)) return h;
    if (det > 0.0f && (t_scaled <= 0.0f || t_scaled > ray.tmax * det)) return h;
    float inv_det = 1.0f / det;
    h.t = t_scaled * inv_det;
    h.b0 = u * inv_det;
    h.b1 = v * inv_det;
    h.b2 = wv * inv_det;
    // Reject t within its rounding error of zero (pbrt-v4): an origin on the triangle's
    // plane must not hit the triangle itself.
    float max_zt = fmax3(ABSF(az), ABSF(bz), ABSF(cz)) * ABSF(w.sz);
    float max_xt = fmax3(ABSF(ax), ABSF(bx), ABSF(cx));
    float max_yt = fmax3(ABSF(ay), ABSF(by), ABSF(cy));
    float delta_z = gamma_bound(3.0f) * max_zt;
    float delta_x = gamma_bound(5.0f) * (max_xt + max_zt);
    float delta_y = gamma_bound(5.0f) * (max_yt + max_zt);
    float delta_e = 2.0f * (gamma_bound(2.0f) * max_xt * max_yt + delta_y * max_xt + delta_x * max_yt);
    float max_e = fmax3(ABSF(u), ABSF(v), ABSF(wv));
    float delta_t = 3.0f * (gamma_bound(3.0f) * max_e * max_zt + delta_e * max_zt + delta_z * max_e) *
                    ABSF(inv_det);
    h.hit = h.t > delta_t && h.t < ray.tmax;
    return h;
}
#if defined(MCPT_OPENCL)
#pragma OPENCL FP_CONTRACT ON
#endif

// Nearest sphere hit with 0 < t < tmax, or -1.
MCPT_FN float intersect_sphere(Ray ray, GpuSphere s) {
    vec3 f = ray.o - V3(s.cx, s.cy, s.cz);
    float a = dot(ray.d, ray.d);
    float b_half = -dot(f, ray.d);
    // Discriminant from the closest-approach vector, not b^2 - 4ac (no cancellation).
    vec3 l = f + ray.d * (b_half / a);
    float r2 = s.radius * s.radius;
    float disc = r2 - dot(l, l);
    if (disc < 0.0f) return -1.0f;
    float q = b_half + (b_half >= 0.0f ? 1.0f : -1.0f) * sqrt(a * disc);
    float c = dot(f, f) - r2;
    float t0 = q != 0.0f ? c / q : 0.0f;
    float t1 = q / a;
    float tnear = MINF(t0, t1), tfar = MAXF(t0, t1);
    if (tnear > 0.0f && tnear < ray.tmax) return tnear;
    if (tfar > 0.0f && tfar < ray.tmax) return tfar;
    return -1.0f;
}

// Narrow [r.x, r.y] to one slab; a direction parallel to the slab (inv = +-inf) keeps the
// range if the origin lies within the slab, boundary included, and empties it otherwise.
MCPT_FN vec2 clip_slab(vec2 r, float o, float inv, float lo, float hi) {
    if (is_nonfinite(inv)) {
        if (o < lo || o > hi) r.y = -1.0f;
        return r;
    }
    float tn = (lo - o) * inv;
    float tf = (hi - o) * inv;
    float g = 1.0f + 2.0f * gamma_bound(3.0f);
    if (tn > tf) {
        float tmp = tn;
        tn = tf;
        tf = tmp;
    }
    r.x = tn > r.x ? tn : r.x;
    r.y = tf * g < r.y ? tf * g : r.y;
    return r;
}

// Parametric range [x, y] of the ray inside a box, conservatively widened (pbrt-v4);
// empty when x > y.
MCPT_FN vec2 intersect_bounds(Ray ray, vec3 bmin, vec3 bmax, vec3 inv_d) {
    vec2 r;
    r.x = 0.0f;
    r.y = ray.tmax;
    r = clip_slab(r, ray.o.x, inv_d.x, bmin.x, bmax.x);
    r = clip_slab(r, ray.o.y, inv_d.y, bmin.y, bmax.y);
    r = clip_slab(r, ray.o.z, inv_d.z, bmin.z, bmax.z);
    return r;
}

// Offset a surface point past its rounding error along the normal, on the side of w, and
// round away so the new origin is strictly on that side (pbrt-v4 OffsetRayOrigin).
MCPT_FN vec3 offset_ray_origin(vec3 p, vec3 p_error, vec3 n, vec3 w) {
    float dist = dot(VABS(n), p_error);
    vec3 offset = n * dist;
    if (dot(w, n) < 0.0f) offset = -offset;
    vec3 po = p + offset;
    po.x = offset.x > 0.0f ? next_float(po.x, 1.0f) : (offset.x < 0.0f ? next_float(po.x, -1.0f) : po.x);
    po.y = offset.y > 0.0f ? next_float(po.y, 1.0f) : (offset.y < 0.0f ? next_float(po.y, -1.0f) : po.y);
    po.z = offset.z > 0.0f ? next_float(po.z, 1.0f) : (offset.z < 0.0f ? next_float(po.z, -1.0f) : po.z);
    return po;
}

MCPT_NAMESPACE_END

#endif  // MCPT_GPU_INTERSECT_H
