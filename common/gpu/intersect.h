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
    // `/`, not DIVF: the meshes ran 3% slower on NVIDIA's OpenCL with DIVF here (lang.h).
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

MCPT_FN vec3 tri_v0(GpuTriangle tri) {
    return V3(tri.v0x, tri.v0y, tri.v0z);
}
MCPT_FN vec3 tri_v1(GpuTriangle tri) {
    return V3(tri.v1x, tri.v1y, tri.v1z);
}
MCPT_FN vec3 tri_v2(GpuTriangle tri) {
    return V3(tri.v2x, tri.v2y, tri.v2z);
}

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
    float delta_e =
        2.0f * (gamma_bound(2.0f) * max_xt * max_yt + delta_y * max_xt + delta_x * max_yt);
    float max_e = fmax3(ABSF(u), ABSF(v), ABSF(wv));
    float delta_t = 3.0f *
                    (gamma_bound(3.0f) * max_e * max_zt + delta_e * max_zt + delta_z * max_e) *
                    ABSF(inv_det);
    h.hit = h.t > delta_t && h.t < ray.tmax;
    return h;
}
#if defined(MCPT_OPENCL) && defined(MCPT_BVH_VECTOR)
// OpenCL on CPU devices: intersect_triangle for four triangles at once, lane for lane the same
// arithmetic, up to the comparisons with the ray's tmax, which the caller makes per lane
// (closer_triangle_hits4: its tmax changes from one triangle to the next).
MCPT_STRUCT(TriHit4) {
    float4 t_scaled, det, t, b1, b2;
    int4 ok;  // the tests that do not depend on tmax passed
};

MCPT_FN TriHit4 intersect_triangle4(Ray ray, WoopRay w, GpuTriangle t0, GpuTriangle t1,
                                    GpuTriangle t2, GpuTriangle t3) {
    // Vertices relative to the ray origin, a lane a triangle, then the axes taken as
    // intersect_triangle takes them.
    float4 a0 = (float4)(t0.v0x, t1.v0x, t2.v0x, t3.v0x) - ray.o.x;
    float4 a1 = (float4)(t0.v0y, t1.v0y, t2.v0y, t3.v0y) - ray.o.y;
    float4 a2 = (float4)(t0.v0z, t1.v0z, t2.v0z, t3.v0z) - ray.o.z;
    float4 b0 = (float4)(t0.v1x, t1.v1x, t2.v1x, t3.v1x) - ray.o.x;
    float4 b1 = (float4)(t0.v1y, t1.v1y, t2.v1y, t3.v1y) - ray.o.y;
    float4 b2 = (float4)(t0.v1z, t1.v1z, t2.v1z, t3.v1z) - ray.o.z;
    float4 c0 = (float4)(t0.v2x, t1.v2x, t2.v2x, t3.v2x) - ray.o.x;
    float4 c1 = (float4)(t0.v2y, t1.v2y, t2.v2y, t3.v2y) - ray.o.y;
    float4 c2 = (float4)(t0.v2z, t1.v2z, t2.v2z, t3.v2z) - ray.o.z;
#define AXIS4(k, x, y, z) ((k) == 0u ? (x) : ((k) == 1u ? (y) : (z)))
    float4 az = AXIS4(w.kz, a0, a1, a2), bz = AXIS4(w.kz, b0, b1, b2), cz = AXIS4(w.kz, c0, c1, c2);
    float4 ax = AXIS4(w.kx, a0, a1, a2) - w.sx * az, ay = AXIS4(w.ky, a0, a1, a2) - w.sy * az;
    float4 bx = AXIS4(w.kx, b0, b1, b2) - w.sx * bz, by = AXIS4(w.ky, b0, b1, b2) - w.sy * bz;
    float4 cx = AXIS4(w.kx, c0, c1, c2) - w.sx * cz, cy = AXIS4(w.ky, c0, c1, c2) - w.sy * cz;
#undef AXIS4
    float4 u = cx * by - cy * bx;
    float4 v = ax * cy - ay * cx;
    float4 wv = bx * ay - by * ax;
    TriHit4 h;
    h.ok = ~(((u < 0.0f) | (v < 0.0f) | (wv < 0.0f)) & ((u > 0.0f) | (v > 0.0f) | (wv > 0.0f)));
    h.det = u + v + wv;
    h.ok &= h.det != 0.0f;
    h.t_scaled = w.sz * (u * az + v * bz + wv * cz);
    float4 inv_det = 1.0f / h.det;
    h.t = h.t_scaled * inv_det;
    h.b1 = v * inv_det;
    h.b2 = wv * inv_det;
    float4 max_zt = fmax(fabs(az), fmax(fabs(bz), fabs(cz))) * fabs(w.sz);
    float4 max_xt = fmax(fabs(ax), fmax(fabs(bx), fabs(cx)));
    float4 max_yt = fmax(fabs(ay), fmax(fabs(by), fabs(cy)));
    float4 delta_z = gamma_bound(3.0f) * max_zt;
    float4 delta_x = gamma_bound(5.0f) * (max_xt + max_zt);
    float4 delta_y = gamma_bound(5.0f) * (max_yt + max_zt);
    float4 delta_e =
        2.0f * (gamma_bound(2.0f) * max_xt * max_yt + delta_y * max_xt + delta_x * max_yt);
    float4 max_e = fmax(fabs(u), fmax(fabs(v), fabs(wv)));
    float4 delta_t = 3.0f *
                     (gamma_bound(3.0f) * max_e * max_zt + delta_e * max_zt + delta_z * max_e) *
                     fabs(inv_det);
    h.ok &= h.t > delta_t;
    return h;
}

// Lane k's hit against tmax, as intersect_triangle decides it.
MCPT_FN bool triangle4_within(float t_scaled, float det, float t, float tmax) {
    if (det < 0.0f && (t_scaled >= 0.0f || t_scaled < tmax * det)) return false;
    if (det > 0.0f && (t_scaled <= 0.0f || t_scaled > tmax * det)) return false;
    return t < tmax;
}
#endif

#if defined(MCPT_OPENCL)
#pragma OPENCL FP_CONTRACT ON
#endif

// Nearest sphere hit with 0 < t < tmax, or -1.
MCPT_FN float intersect_sphere(Ray ray, GpuSphere s) {
    vec3 f = ray.o - V3(s.cx, s.cy, s.cz);
    float a = dot(ray.d, ray.d);
    float b_half = -dot(f, ray.d);
    // Discriminant from the closest-approach vector, not b^2 - 4ac (no cancellation).
    vec3 l = f + ray.d * DIVF(b_half, a);
    float r2 = s.radius * s.radius;
    float disc = r2 - dot(l, l);
    if (disc < 0.0f) return -1.0f;
    float q = b_half + (b_half >= 0.0f ? 1.0f : -1.0f) * sqrt(a * disc);
    float c = dot(f, f) - r2;
    float t0 = q != 0.0f ? DIVF(c, q) : 0.0f;
    float t1 = DIVF(q, a);
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
    po.x = offset.x > 0.0f ? next_float(po.x, 1.0f)
                           : (offset.x < 0.0f ? next_float(po.x, -1.0f) : po.x);
    po.y = offset.y > 0.0f ? next_float(po.y, 1.0f)
                           : (offset.y < 0.0f ? next_float(po.y, -1.0f) : po.y);
    po.z = offset.z > 0.0f ? next_float(po.z, 1.0f)
                           : (offset.z < 0.0f ? next_float(po.z, -1.0f) : po.z);
    return po;
}

MCPT_NAMESPACE_END

#endif  // MCPT_GPU_INTERSECT_H
