// Sampling routines and small vector helpers, each mapping uniforms in [0,1) to a sample.
#ifndef MCPT_GPU_SAMPLING_H
#define MCPT_GPU_SAMPLING_H

#include "lang.h"

MCPT_NAMESPACE_BEGIN

#define MCPT_PI 3.14159265358979323846f
#define MCPT_INV_PI 0.31830988618379067154f
#define MCPT_FLOAT_EPS 5.96046448e-08f  // 2^-24, unit roundoff of float32

// Component k (0, 1, 2) of v: OpenCL C cannot index a vector with a variable.
MCPT_FN float vec3_at(vec3 v, uint k) { return k == 0u ? v.x : (k == 1u ? v.y : v.z); }

MCPT_FN float max_component(vec3 v) { return fmax3(v.x, v.y, v.z); }

MCPT_FN float mean_component(vec3 v) { return (v.x + v.y + v.z) * (1.0f / 3.0f); }

// True unless every component is finite; a bit test that fast-math cannot remove.
MCPT_FN bool is_nonfinite(float x) { return (float_as_uint(x) & 0x7f800000u) == 0x7f800000u; }
MCPT_FN bool is_nonfinite3(vec3 v) {
    return is_nonfinite(v.x) || is_nonfinite(v.y) || is_nonfinite(v.z);
}

// pbrt's gamma(n): bound on the relative error of n chained float operations.
MCPT_FN float gamma_bound(float n) { return (n * MCPT_FLOAT_EPS) / (1.0f - n * MCPT_FLOAT_EPS); }

// The next float away from zero in the direction of `dir` (dir > 0: up, dir < 0: down).
MCPT_FN float next_float(float v, float dir) {
    if (v == 0.0f) v = 0.0f;  // turn -0 into +0 so both step the same way
    uint bits = float_as_uint(v);
    bool up = dir > 0.0f;
    bool positive = v >= 0.0f;
    bits = (up == positive) ? bits + 1u : bits - 1u;
    if (v == 0.0f && !up) bits = 0x80000001u;  // just below zero
    return uint_as_float(bits);
}

// Orthonormal basis around unit n (Duff et al. 2017, branchless).
MCPT_STRUCT(Frame) {
    vec3 t, b, n;
};
MCPT_FN Frame frame_from_normal(vec3 n) {
    float s = n.z >= 0.0f ? 1.0f : -1.0f;
    float a = DIVF(-1.0f, s + n.z);
    float c = n.x * n.y * a;
    Frame f;
    f.t = V3(1.0f + s * n.x * n.x * a, s * c, -s * n.x);
    f.b = V3(c, s + n.y * n.y * a, -n.y);
    f.n = n;
    return f;
}
MCPT_FN vec3 frame_to_world(Frame f, vec3 v) { return f.t * v.x + f.b * v.y + f.n * v.z; }

// Cosine-weighted direction around +z; pdf = cos(theta) / pi.
MCPT_FN vec3 sample_cosine_hemisphere(float u1, float u2) {
    float r = sqrt(u1);
    float phi = 2.0f * MCPT_PI * u2;
    return V3(r * COSF(phi), r * SINF(phi), sqrt(MAXF(0.0f, 1.0f - u1)));
}

// Uniform barycentrics (b1, b2) on a triangle; b0 = 1 - b1 - b2.
MCPT_FN vec2 sample_triangle_barycentrics(float u1, float u2) {
    float su = sqrt(u1);
    vec2 b;
    b.x = u2 * su;
    b.y = 1.0f - su;
    return b;
}

// 1 - cos(theta_max) of the cone subtended by a sphere with sin^2(theta_max) = sin2,
// accurate for tiny cones (a Taylor expansion where 1 - sqrt(1 - x) cancels).
MCPT_FN float one_minus_cos_cone(float sin2) {
    return sin2 < 0.00068523f ? 0.5f * sin2 + 0.125f * sin2 * sin2
                              : 1.0f - sqrt(MAXF(0.0f, 1.0f - sin2));  // sin2 > 1 by an ulp: 1
}

// Uniform direction in a cone around +z with 1 - cos(theta_max) = omc; pdf = 1/(2 pi omc).
MCPT_FN vec3 sample_cone(float u1, float u2, float omc) {
    float one_minus_cos = u1 * omc;
    float cos_t = 1.0f - one_minus_cos;
    float sin_t = sqrt(MAXF(0.0f, one_minus_cos * (2.0f - one_minus_cos)));
    float phi = 2.0f * MCPT_PI * u2;
    return V3(sin_t * COSF(phi), sin_t * SINF(phi), cos_t);
}

// x in [0, 1) with density proportional to (1 - x) a + x b (a, b >= 0, not both 0): the
// inverse of its CDF, written so that it does not cancel where a or b is small (pbrt-v4).
MCPT_FN float sample_linear(float u, float a, float b) {
    float x = DIVF(u * (a + b), a + sqrt((1.0f - u) * a * a + u * b * b));
    return x < 0.99999994f ? x : 0.99999994f;
}

// A point of [0, 1)^2 with density bilinear_pdf(p, w), the corners' weights w = (w00, w10,
// w01, w11) > 0 (first index along x): y from its marginal, then x given y.
MCPT_FN vec2 sample_bilinear(vec2 u, vec4 w) {
    float y = sample_linear(u.y, w.x + w.y, w.z + w.w);
    float x = sample_linear(u.x, w.x + (w.z - w.x) * y, w.y + (w.w - w.y) * y);
    return V2(x, y);
}

// The density of sample_bilinear() at p.
MCPT_FN float bilinear_pdf(vec2 p, vec4 w) {
    float sx = 1.0f - p.x, sy = 1.0f - p.y;
    return DIVF(4.0f * (sx * sy * w.x + p.x * sy * w.y + sx * p.y * w.z + p.x * p.y * w.w),
                w.x + w.y + w.z + w.w);
}

// Power heuristic (beta = 2) for multiple importance sampling.
MCPT_FN float power_heuristic(float pdf_a, float pdf_b) {
    float a = pdf_a * pdf_a;
    float b = pdf_b * pdf_b;
    return a + b > 0.0f ? a / (a + b) : 0.0f;
}

MCPT_NAMESPACE_END

#endif  // MCPT_GPU_SAMPLING_H
