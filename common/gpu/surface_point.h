// The surface at a ray's hit: the point with its rounding-error bound, the geometric and the
// interpolated shading normals, texture coordinates and their derivatives (surface_at).
// Shared verbatim by OpenCL C, GLSL and C++ (integrator.h includes it).
#ifndef MCPT_GPU_SURFACE_POINT_H
#define MCPT_GPU_SURFACE_POINT_H

#include "traverse.h"

MCPT_NAMESPACE_BEGIN

// A hit point with its rounding-error bound, geometric normal (front side / outside), the
// interpolated shading normal (on ng's side), texture coordinates and their derivatives.
MCPT_STRUCT(SurfacePoint) {
    vec3 p;
    vec3 p_error;
    vec3 ng;
    vec3 ns;
    vec2 uv;
    vec3 dpdu, dpdv;
    uint material;
};

MCPT_FN SurfacePoint surface_at(SCENE_PARAMS_ Ray ray, Hit hit) {
    SurfacePoint s;
    s.uv = V2(0.0f, 0.0f);
    s.dpdu = V3S(0.0f);
    s.dpdv = V3S(0.0f);
    if (HAS_FEATURE(FEATURE_SPHERES) && (hit.prim & SPHERE_BIT) != 0u) {
        // Sphere: reproject onto the surface, error bound from pbrt-v4.
        GpuSphere sph = SPHERE(hit.prim & ~SPHERE_BIT);
        vec3 c = V3(sph.cx, sph.cy, sph.cz);
        vec3 rel = ray.o + ray.d * hit.t - c;
        rel = rel * DIVF(sph.radius, length(rel));
        s.p = c + rel;
        s.p_error = VABS(rel) * gamma_bound(5.0f) + VABS(s.p) * gamma_bound(2.0f);
        s.ng = DIVF(rel, sph.radius);
        s.ns = s.ng;
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
        s.ns = s.ng;
        s.material = tri.material;
        if ((HAS_FEATURE(FEATURE_SHADING_NORMALS) || HAS_FEATURE(FEATURE_TEXTURES)) &&
            (PARAM(scene_flags) & SCENE_VERTEX_DATA) != 0u) {
            GpuTriangleAttributes a = ATTRIBUTES(hit.prim);
            if (HAS_FEATURE(FEATURE_SHADING_NORMALS)) {
                // Interpolated vertex normals, turned to the geometric normal's side.
                vec3 ns = normal_from_oct(a.n0) * b0 + normal_from_oct(a.n1) * hit.b1 +
                          normal_from_oct(a.n2) * hit.b2;
                float len = length(ns);
                if (len > 0.0f) s.ns = dot(ns, s.ng) < 0.0f ? DIVF(-ns, len) : DIVF(ns, len);
            }
            if (HAS_FEATURE(FEATURE_TEXTURES)) {
                // Texture coordinates and the surface's derivatives along them (tangents).
                s.uv = V2(a.u0, a.v0) * b0 + V2(a.u1, a.v1) * hit.b1 + V2(a.u2, a.v2) * hit.b2;
                float du1 = a.u1 - a.u0, dv1 = a.v1 - a.v0, du2 = a.u2 - a.u0, dv2 = a.v2 - a.v0;
                float det = du1 * dv2 - du2 * dv1;
                if (det != 0.0f) {
                    vec3 e1 = v1 - v0, e2 = v2 - v0;
                    s.dpdu = DIVF(e1 * dv2 - e2 * dv1, det);
                    s.dpdv = DIVF(e2 * du1 - e1 * du2, det);
                }
            }
        }
    }
    return s;
}

MCPT_NAMESPACE_END

#endif  // MCPT_GPU_SURFACE_POINT_H
