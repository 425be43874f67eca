// Lights that are not surfaces: punctual lights (KHR_lights_punctual: point, spot,
// directional), reached by next-event estimation only, and the environment (an equirectangular
// map or a constant background), sampled by luminance * sin(theta) through two alias tables
// and combined with BSDF sampling by MIS. Their data lives after the texels (shared_types.h).
#ifndef MCPT_GPU_LIGHTS_H
#define MCPT_GPU_LIGHTS_H

#include "sampling.h"
#include "scene_access.h"

MCPT_NAMESPACE_BEGIN

// A light sample for next-event estimation: toward an emitter point, a punctual light or the
// environment. Delta lights (punctual) have pdf = the probability of picking them, and no MIS.
MCPT_STRUCT(LightSample) {
    vec3 wi;       // unit direction from the shading point to the light point
    vec3 p;        // point on the light (unused for lights at infinity)
    vec3 p_error;  // its rounding-error bound
    vec3 n;        // light normal at p (emitting side)
    vec3 le;       // emitted radiance toward the shading point (delta lights: their irradiance;
                   // emissive triangles: over the density of the warp toward the receiver's cosine)
    float pdf;     // solid-angle pdf of choosing this direction (delta lights: the pick's)
    bool valid;
    bool delta;        // a point, spot or directional light: no MIS, no BSDF hit can reach it
    bool at_infinity;  // a direction (directional light, environment): shadow rays are unbounded
};

MCPT_FN LightSample no_light_sample() {
    LightSample ls;
    ls.valid = false;
    ls.delta = false;
    ls.at_infinity = false;
    ls.wi = V3S(0.0f);
    ls.p = V3S(0.0f);
    ls.p_error = V3S(0.0f);
    ls.n = V3S(0.0f);
    ls.le = V3S(0.0f);
    ls.pdf = 0.0f;
    return ls;
}

// ---------------------------------------------------------------- punctual lights

MCPT_FN GpuPunctualLight load_punctual(SCENE_PARAMS_ uint i) {
    uint w = PARAM(punctual_word) + 16u * i;
    vec4 a = SCENE_VEC4(w), b = SCENE_VEC4(w + 4u), c = SCENE_VEC4(w + 8u), d = SCENE_VEC4(w + 12u);
    GpuPunctualLight l;
    l.px = a.x;
    l.py = a.y;
    l.pz = a.z;
    l.type = float_as_uint(a.w);
    l.dx = b.x;
    l.dy = b.y;
    l.dz = b.z;
    l.range = b.w;
    l.r = c.x;
    l.g = c.y;
    l.b = c.z;
    l.spot_scale = c.w;
    l.spot_offset = d.x;
    l.pad0 = 0u;
    l.pad1 = 0u;
    l.pad2 = 0u;
    return l;
}

// The light punctual light i gives x: intensity / d^2 with glTF's range window and spot
// falloff (point, spot), or the irradiance (directional). pdf: the probability `pmf` of
// having picked it.
MCPT_FN LightSample sample_punctual(SCENE_PARAMS_ uint i, vec3 x, float pmf) {
    LightSample ls = no_light_sample();
    GpuPunctualLight l = load_punctual(SCENE_ARGS_ i);
    vec3 dir = V3(l.dx, l.dy, l.dz);
    vec3 le = V3(l.r, l.g, l.b);
    if (l.type == PUNCTUAL_DIRECTIONAL) {
        ls.wi = -dir;
        ls.at_infinity = true;
    } else {
        vec3 to_l = V3(l.px, l.py, l.pz) - x;
        float d2 = dot(to_l, to_l);
        if (!(d2 > 0.0f)) return ls;
        float d = sqrt(d2);
        ls.wi = DIVF(to_l, d);
        ls.p = V3(l.px, l.py, l.pz);
        le = DIVF(le, d2);
        if (l.range > 0.0f) {
            float q = DIVF(d, l.range);
            le = le * clamp(1.0f - q * q * q * q, 0.0f, 1.0f);
        }
        if (l.type == PUNCTUAL_SPOT) {
            float a = clamp(dot(dir, -ls.wi) * l.spot_scale + l.spot_offset, 0.0f, 1.0f);
            le = le * (a * a);
        }
    }
    ls.n = -ls.wi;
    ls.le = le;
    ls.pdf = pmf;
    ls.delta = true;
    ls.valid = max_component(le) > 0.0f && pmf > 0.0f;
    return ls;
}

// One step of picking an item in proportion to its weight from a stream of weights with one
// uniform (weighted reservoir sampling): `total` is the weights so far, this one's included.
// The item replaces the pick with probability w / total, and u is rescaled into [0, 1) for
// the next step, so the pick is item i with probability w_i / (sum of all weights).
MCPT_STRUCT(StreamPick) {
    bool take;
    float u;
};

MCPT_FN StreamPick stream_pick(float u, float w, float total) {
    StreamPick r;
    float q = w / total;
    r.take = u < q;
    r.u = MINF(r.take ? u / q : (u - q) / (1.0f - q), 0.99999994f);
    return r;
}

// ---------------------------------------------------------------- the environment

// The unit direction of map coordinates (u, v) in [0, 1]^2 (v = 0 at +Y), turned by the
// rotation: theta = pi v from +Y, phi = 2 pi (u - 1/2) from +X toward +Z (Cycles' mapping of
// a world texture, seen through the glTF exporter's axes: Blender's +X, -Y, +Z are X, Z, Y).
MCPT_FN vec3 env_direction(SCENE_PARAMS_ float u, float v) {
    float theta = MCPT_PI * v;
    float phi = 2.0f * MCPT_PI * (u + PARAM(env_u_shift) - 0.5f);
    float s = SINF(theta);
    return V3(s * COSF(phi), COSF(theta), s * SINF(phi));
}

// The texel (x, y): radiance rgb, and the pdf w of the uv square it covers.
MCPT_FN vec4 env_texel(SCENE_PARAMS_ uint x, uint y) {
    return SCENE_VEC4(PARAM(env_word) + 4u * (y * PARAM(env_width) + x));
}

// Radiance at map coordinates (u, v): bilinear between the four nearest texel centres (u
// wraps around, v clamps at the poles).
MCPT_FN vec3 env_bilinear(SCENE_PARAMS_ float u, float v) {
    uint w = PARAM(env_width), h = PARAM(env_height);
    float fx = u * F32(w) - 0.5f, fy = v * F32(h) - 0.5f;
    float x0f = floor(fx), y0f = floor(fy);
    float tx = fx - x0f, ty = fy - y0f;
    int x0 = I32(x0f), y0 = I32(y0f);
    uint xa = U32((x0 + I32(w)) % I32(w)), xb = U32((x0 + 1) % I32(w));
    uint ya = U32(max(y0, 0)), yb = U32(min(y0 + 1, I32(h) - 1));
    vec4 a = env_texel(SCENE_ARGS_ xa, ya), b = env_texel(SCENE_ARGS_ xb, ya);
    vec4 c = env_texel(SCENE_ARGS_ xa, yb), d = env_texel(SCENE_ARGS_ xb, yb);
    vec3 top = V3(a.x, a.y, a.z) * (1.0f - tx) + V3(b.x, b.y, b.z) * tx;
    vec3 bottom = V3(c.x, c.y, c.z) * (1.0f - tx) + V3(d.x, d.y, d.z) * tx;
    return top * (1.0f - ty) + bottom * ty;
}

// Map coordinates (u, v) of unit direction d.
MCPT_FN vec2 env_uv(SCENE_PARAMS_ vec3 d) {
    float u = ATAN2(d.z, d.x) * (0.5f / MCPT_PI) + 0.5f - PARAM(env_u_shift);
    float v = acos(clamp(d.y, -1.0f, 1.0f)) * (1.0f / MCPT_PI);
    return V2(u - floor(u), v);
}

// The texel a unit direction falls in: its radiance and the pdf w of its uv square. Where
// next-event estimation competes (MIS), radiance is read so, per texel, and the pdf follows
// it exactly (bilinear radiance there, sampled per texel, had 12x the variance of NEE on a
// one-texel sun: docs/lights.md).
MCPT_FN vec4 env_lookup(SCENE_PARAMS_ vec3 d) {
    vec2 uv = env_uv(SCENE_ARGS_ d);
    uint w = PARAM(env_width), h = PARAM(env_height);
    uint x = min(U32(uv.x * F32(w)), w - 1u);
    uint y = min(U32(uv.y * F32(h)), h - 1u);
    return env_texel(SCENE_ARGS_ x, y);
}

// The radiance seen toward d where nothing else samples it (camera rays, and rays after a
// specular bounce): bilinear, so a low-resolution map behind the scene is not blocky.
MCPT_FN vec3 env_seen(SCENE_PARAMS_ vec3 d) {
    vec2 uv = env_uv(SCENE_ARGS_ d);
    return env_bilinear(SCENE_ARGS_ uv.x, uv.y);
}

// Solid-angle pdf of sampling direction d with texel t (without the light pick): the uv pdf
// over the Jacobian 2 pi^2 sin(theta).
MCPT_FN float env_solid_angle_pdf(vec4 t, vec3 d) {
    float sin_theta = sqrt(d.x * d.x + d.z * d.z);  // accurate near the poles, unlike 1 - y^2
    return sin_theta > 0.0f ? DIVF(t.w, 2.0f * MCPT_PI * MCPT_PI * sin_theta) : 0.0f;
}

// The interval of a CDF table at word `table` (n + 1 ascending floats from 0 to 1) that holds
// u, with u's place in it as a fresh uniform in [0, 1) (the position inside the texel). Unlike
// an alias table the map is monotonic, so well-spread uniforms stay well spread over the map
// (Sobol points stratify the environment's samples). A guide table follows the CDF (n words:
// the interval holding k / n), so the search starts from the intervals of u's bucket, mostly
// one (Chen and Asau's cutpoints): two dependent reads instead of log2(n).
MCPT_STRUCT(CdfPick) {
    uint index;
    float u;
};

MCPT_FN CdfPick cdf_pick(SCENE_PARAMS_ uint table, uint n, float u) {
    // Invariant: cdf[lo] <= u < cdf[hi] (cdf[0] = 0, cdf[n] = 1, u < 1), from u's bucket;
    // where rounding of u * n missed it by one, from the whole table.
    uint bucket = min(U32(u * F32(n)), n - 1u);
    uint guide = table + n + 1u;
    uint lo = SCENE_WORD(guide + bucket);
    uint hi = bucket + 1u < n ? SCENE_WORD(guide + bucket + 1u) + 1u : n;
    if (uint_as_float(SCENE_WORD(table + lo)) > u) lo = 0u;
    if (uint_as_float(SCENE_WORD(table + hi)) <= u) hi = n;
    while (hi - lo > 1u) {
        uint mid = (lo + hi) >> 1u;
        if (uint_as_float(SCENE_WORD(table + mid)) <= u)
            lo = mid;
        else
            hi = mid;
    }
    float c0 = uint_as_float(SCENE_WORD(table + lo));
    float c1 = uint_as_float(SCENE_WORD(table + lo + 1u));
    CdfPick p;
    p.index = lo;
    p.u = clamp((u - c0) / (c1 - c0), 0.0f, 0.99999994f);
    return p;
}

// A direction toward the environment by the texels' weights (gpu_scene.cpp: luminance, or its
// excess over the mean, times sin(theta)): a row by the rows' CDF, a column by that row's, then
// a uniform point of the texel. pdf: solid angle, times `pmf` (the pick of the environment).
MCPT_FN LightSample sample_environment(SCENE_PARAMS_ float u1, float u2, float pmf) {
    LightSample ls = no_light_sample();
    uint w = PARAM(env_width), h = PARAM(env_height);
    CdfPick row = cdf_pick(SCENE_ARGS_ PARAM(env_rows_word), h, u1);
    CdfPick col = cdf_pick(SCENE_ARGS_ PARAM(env_cols_word) + (2u * w + 1u) * row.index, w, u2);
    float u = DIVF(F32(col.index) + col.u, F32(w));
    float v = DIVF(F32(row.index) + row.u, F32(h));
    vec4 t = env_texel(SCENE_ARGS_ col.index, row.index);
    ls.wi = env_direction(SCENE_ARGS_ u, v);
    ls.pdf = pmf * env_solid_angle_pdf(t, ls.wi);
    ls.le = V3(t.x, t.y, t.z);
    ls.at_infinity = true;
    ls.n = -ls.wi;
    ls.valid = ls.pdf > 0.0f;
    return ls;
}

MCPT_NAMESPACE_END

#endif  // MCPT_GPU_LIGHTS_H
