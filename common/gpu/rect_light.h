// Emissive rectangles made of two triangles, sampled as one spherical rectangle (Ureña,
// Fajardo and King 2013): next-event estimation draws directions uniformly over the solid
// angle the whole rectangle subtends, so a receiver beside the light no longer sees its two
// halves picked half and half by power, each with a pdf of its own solid angle. The host pairs
// the triangles (common/render/rect_lights.cpp) and marks their material MAT_RECT_LIGHT; each
// half is a right triangle, so the rectangle comes back from either: its corner at the right
// angle, its edges to the other two vertices. The same bounds as for triangles decide where
// area sampling takes over (triangle_light.h), and rect_solid_angle() decides for next-event
// estimation and the MIS weight of BSDF-sampled hits alike; the same warp toward the
// receiver's cosine as for triangles applies (cosine_warp).
#ifndef MCPT_GPU_RECT_LIGHT_H
#define MCPT_GPU_RECT_LIGHT_H

#include "triangle_light.h"

MCPT_NAMESPACE_BEGIN

MCPT_STRUCT(RectLight) {
    vec3 c;   // the corner
    vec3 ex;  // the edges from it, at a right angle
    vec3 ey;
};

// Whether an emissive triangle of material m is half of a rectangle: where the scene has lone
// emissive triangles too (FEATURE_TRIANGLE_LIGHTS), its material says; else every one is.
MCPT_FN bool is_rect_light(GpuMaterial m) {
    return HAS_FEATURE(FEATURE_RECT_LIGHTS) &&
           (!HAS_FEATURE(FEATURE_TRIANGLE_LIGHTS) || (m.type & MAT_RECT_LIGHT) != 0u);
}

// The rectangle whose half is triangle (v0, v1, v2): the corner at the vertex whose angle is
// nearest a right angle (the host pairs only triangles where that is unambiguous).
MCPT_FN RectLight rect_of_triangle(vec3 v0, vec3 v1, vec3 v2) {
    vec3 e01 = v1 - v0, e02 = v2 - v0, e12 = v2 - v1;
    float l01 = length(e01), l02 = length(e02), l12 = length(e12);
    float c0 = ABSF(dot(e01, e02)) / (l01 * l02);
    float c1 = ABSF(dot(e01, e12)) / (l01 * l12);
    float c2 = ABSF(dot(e02, e12)) / (l02 * l12);
    RectLight r;
    if (c0 <= c1 && c0 <= c2) {
        r.c = v0, r.ex = e01, r.ey = e02;
    } else if (c1 <= c2) {
        r.c = v1, r.ex = v2 - v1, r.ey = v0 - v1;
    } else {
        r.c = v2, r.ex = v0 - v2, r.ey = v1 - v2;
    }
    return r;
}

MCPT_FN float rect_area(RectLight r) {
    return length(cross(r.ex, r.ey));
}

// The solid angle of the rectangle at x where next-event estimation samples it by solid angle,
// else 0 (by area): the two halves' solid angles (Van Oosterom and Strackee, as
// spherical_triangle_area_at: accurate where the sum of the spherical rectangle's angles less
// 2 pi cancels), within the triangles' bounds, and only where the rectangle is not far for its
// size.
MCPT_FN float rect_solid_angle(SCENE_PARAMS_ RectLight r, vec3 x) {
    if ((PARAM(scene_flags) & SCENE_TRIANGLE_LIGHTS_BY_AREA) != 0u) return 0.0f;
    vec3 to_centre = r.c + (r.ex + r.ey) * 0.5f - x;
    if (!(rect_area(r) >= SOLID_ANGLE_WORTH * dot(to_centre, to_centre))) return 0.0f;
    // The unit directions to the corners, each normalised once for both halves.
    vec3 c = r.c - x, a = c + r.ex, b = a + r.ey, d = c + r.ey;
    float lc = length(c), la = length(a), lb = length(b), ld = length(d);
    if (!(lc > 0.0f && la > 0.0f && lb > 0.0f && ld > 0.0f)) return 0.0f;
    c = c * (1.0f / lc), a = a * (1.0f / la), b = b * (1.0f / lb), d = d * (1.0f / ld);
    float cb = dot(c, b);
    float omega =
        2.0f * atan2_portable(ABSF(dot(c, cross(a, b))), 1.0f + dot(c, a) + dot(a, b) + cb) +
        2.0f * atan2_portable(ABSF(dot(c, cross(b, d))), 1.0f + cb + dot(b, d) + dot(d, c));
    return omega >= MIN_TRIANGLE_SOLID_ANGLE && omega <= MAX_TRIANGLE_SOLID_ANGLE ? omega : 0.0f;
}

// The rectangle's coordinates (s, t) in [0, 1]^2 of a direction from x uniformly distributed
// over the spherical rectangle of solid angle omega (> 0), from uniforms u (Ureña et al.,
// as pbrt-v4 writes it): in the frame of the edges, with the rectangle's plane at z0 < 0,
// u.x fixes the sub-rectangle of area u.x * omega and so x along the first edge, then u.y a
// height uniform along the second. The angle au = u.x * omega - g2 - g3 enters only through
// its sine and cosine, composed from those of u.x * omega and of the inner angles g2, g3
// (their planes' normals' dot and cross products): no inverse trigonometry.
MCPT_FN vec2 sample_spherical_rectangle(RectLight r, vec3 x, float omega, vec2 u) {
    float exl = length(r.ex), eyl = length(r.ey);
    vec3 fx = r.ex * (1.0f / exl), fy = r.ey * (1.0f / eyl);
    vec3 d = r.c - x;
    float x0 = dot(d, fx), y0 = dot(d, fy), z0 = -ABSF(dot(d, cross(fx, fy)));
    float x1 = x0 + exl, y1 = y0 + eyl;
    // The normals of the planes through x and three of the edges.
    vec3 v00 = V3(x0, y0, z0), v01 = V3(x0, y1, z0), v10 = V3(x1, y0, z0), v11 = V3(x1, y1, z0);
    vec3 n0 = normalize(cross(v00, v10)), n2 = normalize(cross(v11, v01));
    vec3 n3 = normalize(cross(v01, v00));
    // sin and cos of g = g2 + g3, the inner angles between -n2 and n3, -n3 and n0.
    float cos_g2 = -dot(n2, n3), sin_g2 = length(cross(n2, n3));
    float cos_g3 = -dot(n3, n0), sin_g3 = length(cross(n3, n0));
    float cos_g = cos_g2 * cos_g3 - sin_g2 * sin_g3, sin_g = sin_g2 * cos_g3 + cos_g2 * sin_g3;
    // x along the first edge: the sub-rectangle's area u.x * omega.
    float sin_w = SINF(u.x * omega), cos_w = COSF(u.x * omega);
    float sin_au = sin_w * cos_g - cos_w * sin_g, cos_au = cos_w * cos_g + sin_w * sin_g;
    float b0 = n0.z, b1 = n2.z;
    float fu = DIVF(cos_au * b0 - b1, sin_au);
    float cu = 1.0f / sqrt(fu * fu + b0 * b0);
    cu = clamp(fu < 0.0f ? -cu : cu, -0.99999994f, 0.99999994f);
    float xu = clamp(DIVF(-(cu * z0), sqrt(MAXF(0.0f, 1.0f - cu * cu))), x0, x1);
    // y along the second edge: uniform in the height h of the direction's projection.
    float dd2 = xu * xu + z0 * z0;
    float h0 = y0 * inversesqrt(dd2 + y0 * y0), h1 = y1 * inversesqrt(dd2 + y1 * y1);
    float hv = h0 + u.y * (h1 - h0), hv2 = hv * hv;
    float yv = hv2 < 0.9999999f ? DIVF(hv * sqrt(dd2), sqrt(1.0f - hv2)) : y1;
    return V2(clamp(DIVF(xu - x0, exl), 0.0f, 1.0f), clamp(DIVF(yv - y0, eyl), 0.0f, 1.0f));
}

// A point (s, t) of the rectangle for next-event estimation from x: by solid angle where
// omega = rect_solid_angle() > 0, else uniform in area.
MCPT_FN vec2 sample_rect_light(RectLight r, vec3 x, float omega, vec2 u) {
    return omega > 0.0f ? sample_spherical_rectangle(r, x, omega, u) : u;
}

MCPT_NAMESPACE_END

#endif  // MCPT_GPU_RECT_LIGHT_H
