// Emissive triangles sampled by the solid angle they subtend at the receiver (Arvo 1995):
// next-event estimation draws directions uniformly over the spherical triangle, so its pdf is
// the pick's probability over the solid angle, and nothing in it grows as the receiver nears
// the light (area sampling's distance^2 / cos does, beside a light's edge). Where the solid
// angle is too small for float arithmetic (a tiny or far light, a receiver in or near the
// light's plane) or nearly a hemisphere (a huge light close by), the triangle is sampled by
// area instead (pbrt-v4's bounds), and so it is where the light is far for its size, where
// both sample alike and area sampling costs less. triangle_solid_angle() decides and
// triangle_light_pdf() computes the pdf, for next-event estimation and for the MIS weight of
// BSDF-sampled hits alike. Where the light spans 0.2 sr or more, the uniforms are first warped
// toward the receiver's cosine (cosine_warp, pbrt-v4's bilinear warp; the MIS weights keep the
// unwarped pdf).
#ifndef MCPT_GPU_TRIANGLE_LIGHT_H
#define MCPT_GPU_TRIANGLE_LIGHT_H

#include "sampling.h"
#include "scene_access.h"

MCPT_NAMESPACE_BEGIN

#define MIN_TRIANGLE_SOLID_ANGLE 3.0e-4f  // sr: below, sampled by area
#define MAX_TRIANGLE_SOLID_ANGLE 6.22f    // sr: above (2 pi is a hemisphere), by area
#define SOLID_ANGLE_WORTH 0.05f           // area / distance^2: below, by area

// atan2(y, x) for y >= 0 from + - * / alone, within 2e-7 of the true angle: the same bits on
// every device (the drivers' own atan2 differ in the last places, and the solid angle scales
// every sample of the light, so OpenCL's and Vulkan's same-seed images parted). Reduced to
// |t| <= tan(pi / 8), where the odd Taylor series to t^17 is within 5e-9.
MCPT_FN float atan2_portable(float y, float x) {
    float ax = ABSF(x);
    bool swap = y > ax;
    float t = swap ? DIVF(ax, y) : (ax > 0.0f ? DIVF(y, ax) : 0.0f);  // in [0, 1]
    bool shift = t > 0.41421356f;
    if (shift) t = DIVF(t - 1.0f, t + 1.0f);
    float z = t * t;
    float series = 1.0f / 17.0f;
    series = series * z - 1.0f / 15.0f;
    series = series * z + 1.0f / 13.0f;
    series = series * z - 1.0f / 11.0f;
    series = series * z + 1.0f / 9.0f;
    series = series * z - 1.0f / 7.0f;
    series = series * z + 1.0f / 5.0f;
    series = series * z - 1.0f / 3.0f;
    float a = t + t * z * series;
    if (shift) a += 0.25f * MCPT_PI;
    if (swap) a = 0.5f * MCPT_PI - a;
    return x < 0.0f ? MCPT_PI - a : a;
}

// The solid angle triangle (v0, v1, v2) subtends at x (0 where x is a vertex): Van Oosterom
// and Strackee's formula, tan(omega / 2) = |a . (b x c)| / (1 + a.b + b.c + c.a) for the unit
// directions a, b, c.
MCPT_FN float spherical_triangle_area_at(vec3 v0, vec3 v1, vec3 v2, vec3 x) {
    vec3 a = v0 - x, b = v1 - x, c = v2 - x;
    float la = length(a), lb = length(b), lc = length(c);
    if (!(la > 0.0f && lb > 0.0f && lc > 0.0f)) return 0.0f;
    a = a * (1.0f / la), b = b * (1.0f / lb), c = c * (1.0f / lc);
    return 2.0f *
           atan2_portable(ABSF(dot(a, cross(b, c))), 1.0f + dot(a, b) + dot(b, c) + dot(c, a));
}

// The solid angle triangle (v0, v1, v2) subtends at x, where float arithmetic holds it (within
// the bounds above), else 0.
MCPT_FN float triangle_solid_angle_at(vec3 v0, vec3 v1, vec3 v2, vec3 x) {
    float omega = spherical_triangle_area_at(v0, v1, v2, x);
    return omega >= MIN_TRIANGLE_SOLID_ANGLE && omega <= MAX_TRIANGLE_SOLID_ANGLE ? omega : 0.0f;
}

// The solid angle of the triangle where next-event estimation samples it by solid angle, else
// 0: by area where the triangle is far for its size (its area over the squared distance to
// its centroid below SOLID_ANGLE_WORTH: there distance^2 / cos hardly varies over it, and
// area sampling costs less), where triangle_solid_angle_at() gives 0, and in scenes that ask
// for it (render --triangle-light-sampling area).
MCPT_FN float triangle_solid_angle(SCENE_PARAMS_ vec3 v0, vec3 v1, vec3 v2, vec3 x) {
    if ((PARAM(scene_flags) & SCENE_TRIANGLE_LIGHTS_BY_AREA) != 0u) return 0.0f;
    vec3 to_centre = (v0 + v1 + v2) * (1.0f / 3.0f) - x;
    float twice_area = length(cross(v1 - v0, v2 - v0));
    if (!(twice_area >= 2.0f * SOLID_ANGLE_WORTH * dot(to_centre, to_centre))) return 0.0f;
    return triangle_solid_angle_at(v0, v1, v2, x);
}

// A direction uniformly distributed over the spherical triangle of unit directions a, b, c
// and solid angle omega (> 0), from uniforms u (Arvo 1995): the sub-triangle a b c' of area
// u.x * omega fixes c' on the arc from a to c, then u.y a point on the arc from b to c'. The
// angle alpha at a enters only through its sine and cosine, taken from the arcs' planes.
MCPT_FN vec3 sample_spherical_triangle(vec3 a, vec3 b, vec3 c, float omega, vec2 u) {
    vec3 n_ab = normalize(cross(a, b)), n_ac = normalize(cross(a, c));
    float cos_a = clamp(dot(n_ab, n_ac), -1.0f, 1.0f);
    float sin_a = length(cross(n_ab, n_ac));
    // sin and cos of (area' - alpha).
    float sin_ap = SINF(u.x * omega), cos_ap = COSF(u.x * omega);
    float s = sin_ap * cos_a - cos_ap * sin_a, t = cos_ap * cos_a + sin_ap * sin_a;
    float p = t - cos_a, q = s + sin_a * dot(a, b);
    // cos of the arc from a to c'.
    float cos_ac = DIVF((q * t - p * s) * cos_a - q, (q * s + p * t) * sin_a);
    cos_ac = cos_ac > -1.0f ? MINF(cos_ac, 1.0f) : -1.0f;  // (NaN: -1)
    vec3 cp = a * cos_ac + normalize(c - a * dot(c, a)) * sqrt(MAXF(0.0f, 1.0f - cos_ac * cos_ac));
    // Uniform in the cosine of the angle from b along the arc to c'.
    float z = 1.0f - u.y * (1.0f - dot(cp, b));
    vec3 along = cp - b * dot(cp, b);
    float len = length(along);
    return len > 0.0f ? b * z + along * (sqrt(MAXF(0.0f, 1.0f - z * z)) / len) : b;
}

// Barycentrics (b1, b2) where the ray from x along w meets the plane of (v0, v1, v2), kept in
// the triangle (the sampled direction is inside it up to rounding).
MCPT_FN vec2 triangle_barycentrics_along(vec3 v0, vec3 v1, vec3 v2, vec3 x, vec3 w) {
    vec3 e1 = v1 - v0, e2 = v2 - v0, s = x - v0;
    vec3 s1 = cross(w, e2);
    float divisor = dot(s1, e1);
    if (divisor == 0.0f) return V2(1.0f / 3.0f, 1.0f / 3.0f);
    float b1 = clamp(DIVF(dot(s, s1), divisor), 0.0f, 1.0f);
    float b2 = clamp(DIVF(dot(w, cross(s, e1)), divisor), 0.0f, 1.0f);
    float sum = b1 + b2;
    return sum > 1.0f ? V2(b1 / sum, b2 / sum) : V2(b1, b2);
}

// A point of triangle (v0, v1, v2) for next-event estimation from x: by solid angle where
// omega = triangle_solid_angle() > 0, else uniform in area. Barycentrics (b1, b2).
MCPT_FN vec2 sample_triangle_light(vec3 v0, vec3 v1, vec3 v2, vec3 x, float omega, vec2 u) {
    if (!(omega > 0.0f)) return sample_triangle_barycentrics(u.x, u.y);
    vec3 a = normalize(v0 - x), b = normalize(v1 - x), c = normalize(v2 - x);
    return triangle_barycentrics_along(v0, v1, v2, x, sample_spherical_triangle(a, b, c, omega, u));
}

// The weight of one corner in the warp toward the receiver's cosine (pbrt-v4's bilinear warp
// of the uniforms before a spherical triangle or rectangle maps them): |cos| between the
// receiver's shading normal ns and the direction to the point that the unit square's corner
// maps to, at least 0.01 (a corner below the horizon still gets samples: the warp is a
// density, not a cut). The triangle's corners: (0, 0) and (1, 0) map to v1, (0, 1) to v0,
// (1, 1) to v2 (sample_spherical_triangle: u.x = 0 leaves c' at a, u.y = 0 gives b).
MCPT_FN float cosine_warp_weight(vec3 ns, vec3 to_corner) {
    return MAXF(0.01f, ABSF(dot(ns, to_corner)) * inversesqrt(dot(to_corner, to_corner)));
}

// The uniforms u warped by the corners' weights w (sample_bilinear), and the warp's density
// there: (u'.x, u'.y, density).
MCPT_FN vec3 cosine_warp(vec2 u, vec4 w) {
#ifdef MCPT_NEGATIVE_CONTROL_WARP  // tests: toward the wrong corners (mirrored: noisier)
    w = V4(w.y, w.x, w.w, w.z);
#endif
    vec2 q = sample_bilinear(u, w);
#ifdef MCPT_NEGATIVE_CONTROL_WARP_DENSITY  // tests: the warp's density forgotten (biased)
    return V3(q.x, q.y, 1.0f);
#else
    return V3(q.x, q.y, bilinear_pdf(q, w));
#endif
}

// Whether next-event estimation warps the uniforms toward the receiver's cosine, where the
// light is sampled by solid angle (omega > 0): where it spans WARP_MIN_SOLID_ANGLE or more
// (the warp's gain beside large lights at no cost elsewhere: docs/lights.md), everywhere, or
// nowhere, as the scene asks.
#define WARP_MIN_SOLID_ANGLE 0.2f  // sr, about 29 degrees across
MCPT_FN bool cosine_warp_on(SCENE_PARAMS_ float omega) {
    uint flags = PARAM(scene_flags);
    if ((flags & SCENE_TRIANGLE_LIGHTS_COSINE) != 0u) return omega > 0.0f;
    return omega >= WARP_MIN_SOLID_ANGLE && (flags & SCENE_TRIANGLE_LIGHTS_UNIFORM) == 0u;
}

// The solid-angle pdf with which next-event estimation from x reaches a point of the triangle
// at squared distance dist2, where the light's normal makes cos_l with the direction: the
// pick's probability over the solid angle, or (omega 0) over the area, converted.
MCPT_FN float triangle_light_pdf(float pick, float omega, float area, float dist2, float cos_l) {
    return omega > 0.0f ? DIVF(pick, omega) : DIVF(pick * dist2, area * cos_l);
}

MCPT_NAMESPACE_END

#endif  // MCPT_GPU_TRIANGLE_LIGHT_H
