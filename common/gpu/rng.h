// Counter-based random numbers: a hash of (pixel, sample index, dimension, seed), so every
// backend reproduces the same sample stream with no state to store or carry.
// PCG4D: Jarzynski & Olano, "Hash Functions for GPU Rendering", JCGT 2020.
#ifndef MCPT_GPU_RNG_H
#define MCPT_GPU_RNG_H

#include "lang.h"

MCPT_NAMESPACE_BEGIN

// (In four scalars: PoCL compiled the vector form's chain through lane inserts and extracts.)
MCPT_FN uvec4 pcg4d(uvec4 v) {
    uint x = v.x * 1664525u + 1013904223u, y = v.y * 1664525u + 1013904223u;
    uint z = v.z * 1664525u + 1013904223u, w = v.w * 1664525u + 1013904223u;
    x += y * w;
    y += z * x;
    z += x * y;
    w += y * z;
    x ^= x >> 16u;
    y ^= y >> 16u;
    z ^= z >> 16u;
    w ^= w >> 16u;
    x += y * w;
    y += z * x;
    z += x * y;
    w += y * z;
    return UV4(x, y, z, w);
}

// Top 24 bits to a float in [0, 1).
MCPT_FN float uint_to_unit_float(uint x) { return F32(x >> 8u) * (1.0f / 16777216.0f); }

// Four independent uniforms for dimension group `dim` of sample `sample_index` of `pixel`.
MCPT_FN vec4 rng4(uint pixel, uint sample_index, uint dim, uint seed) {
    uvec4 h = pcg4d(UV4(pixel, sample_index, dim, seed));
    vec4 u;
    u.x = uint_to_unit_float(h.x);
    u.y = uint_to_unit_float(h.y);
    u.z = uint_to_unit_float(h.z);
    u.w = uint_to_unit_float(h.w);
    return u;
}

MCPT_NAMESPACE_END

#endif  // MCPT_GPU_RNG_H
