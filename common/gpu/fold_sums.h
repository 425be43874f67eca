// Exact sums on the device, for reproducible renders: a group's float sums become 128-bit
// fixed-point numbers and are added as integers, so the total does not depend on how the
// additions are grouped. The same arithmetic as the host's common/render/exact_sums.h
// (to_exact, add_exact), in 32-bit words, low word first; fold_sums_test.cpp checks the two
// against each other bit for bit.
#ifndef MCPT_GPU_FOLD_SUMS_H
#define MCPT_GPU_FOLD_SUMS_H

#include "lang.h"
#include "sampling.h"
#include "shared_types.h"

MCPT_NAMESPACE_BEGIN

// A 128-bit value and whether the operation that made it stayed in range.
MCPT_STRUCT(ExactTerm) {
    uvec4 w;
    bool ok;
};

// -a, two's complement.
MCPT_FN uvec4 exact_negate(uvec4 a) {
    uvec4 n = UV4(~a.x, ~a.y, ~a.z, ~a.w);
    n.x += 1u;
    uint c = n.x == 0u ? 1u : 0u;
    n.y += c;
    c = (c != 0u && n.y == 0u) ? 1u : 0u;
    n.z += c;
    c = (c != 0u && n.z == 0u) ? 1u : 0u;
    n.w += c;
    return n;
}

// value * 2^50 truncated toward zero (to_exact); not ok for NaN, Inf and |value * 2^50| >=
// 2^100.
MCPT_FN ExactTerm exact_term(float value) {
    uint bits = float_as_uint(value);
    uint e = (bits >> 23) & 255u;
    // |value| = m * 2^(max(e, 1) - 150), so |value| * 2^50 = m * 2^s.
    uint m = (bits & 0x7fffffu) | (e != 0u ? 0x800000u : 0u);
    int s = I32(e != 0u ? e : 1u) - 100;
    ExactTerm t;
    t.ok = e != 255u && s <= 76;  // m < 2^24: m * 2^s < 2^100 while s <= 76
    t.w = UV4(0u, 0u, 0u, 0u);
    if (!t.ok) return t;
    if (s < 0) {
        // Bits below the binary point are dropped (truncation of the magnitude).
        t.w.x = s <= -32 ? 0u : m >> U32(-s);
    } else {
        // m shifted into the word s / 32 and the next.
        uint q = U32(s) >> 5, r = U32(s) & 31u;
        uint lo = m << r, hi = r == 0u ? 0u : m >> (32u - r);
        if (q == 0u) {
            t.w.x = lo;
            t.w.y = hi;
        } else if (q == 1u) {
            t.w.y = lo;
            t.w.z = hi;
        } else {
            t.w.z = lo;
            t.w.w = hi;
        }
    }
    if ((bits >> 31) != 0u) t.w = exact_negate(t.w);
    return t;
}

// a + b (add_exact); not ok when the sum's high 64 bits leave (-2^62, 2^62).
MCPT_FN ExactTerm exact_add(uvec4 a, uvec4 b) {
    ExactTerm t;
    t.w.x = a.x + b.x;
    uint c = t.w.x < a.x ? 1u : 0u;
    uint y = a.y + b.y;
    t.w.y = y + c;
    c = (y < a.y || t.w.y < y) ? 1u : 0u;
    uint z = a.z + b.z;
    t.w.z = z + c;
    c = (z < a.z || t.w.z < z) ? 1u : 0u;
    t.w.w = a.w + b.w + c;
    // The high 64 bits, hi = int(w) * 2^32 + z, inside (-2^62, 2^62): int(w) below 2^30, or
    // above -2^30, or -2^30 with z > 0 (compared as unsigned words).
    t.ok = t.w.w < 0x40000000u || t.w.w > 0xC0000000u || (t.w.w == 0xC0000000u && t.w.z != 0u);
    return t;
}

// acc + value * 2^50 truncated (to_exact, then add_exact).
MCPT_FN ExactTerm exact_accumulate(uvec4 acc, float value) {
    ExactTerm t = exact_term(value);
    if (!t.ok) return t;
    return exact_add(acc, t.w);
}

// The two 64-bit counts (low words first: non-finite samples, rays) plus a group's float
// counts (integers below 2^24).
MCPT_FN uvec4 counts_add(uvec4 c, float nonfinite, float rays) {
    uint n = U32(nonfinite), r = U32(rays);
    uvec4 s = UV4(c.x + n, c.y, c.z + r, c.w);
    if (s.x < c.x) s.y += 1u;
    if (s.z < c.z) s.w += 1u;
    return s;
}

// A pixel's exact sums (EXACT_VEC4_PER_PIXEL uvec4, shared_types.h): the sums (rgb), the
// squares (rgb), then the counts.
MCPT_STRUCT(ExactPixel) {
    uvec4 w[EXACT_VEC4_PER_PIXEL];
};

MCPT_STRUCT(FoldStep) {
    ExactPixel px;
    bool ok;
};

// One pixel's float sums of a whole group (the accumulation buffer's two vec4) added to its
// exact sums (FOLD_ADD), or taking their place (FOLD_STORE).
MCPT_FN FoldStep fold_pixel(vec4 sum, vec4 sum_sq, ExactPixel px, uint mode) {
    uvec4 zero = UV4(0u, 0u, 0u, 0u);
    bool store = mode == FOLD_STORE;
    vec3 s = V3(sum.x, sum.y, sum.z), q = V3(sum_sq.x, sum_sq.y, sum_sq.z);
    FoldStep f;
    f.ok = true;
    for (uint c = 0u; c < 3u; ++c) {
        ExactTerm t = exact_accumulate(store ? zero : px.w[c], vec3_at(s, c));
        f.px.w[c] = t.w;
        f.ok = f.ok && t.ok;
        t = exact_accumulate(store ? zero : px.w[3u + c], vec3_at(q, c));
        f.px.w[3u + c] = t.w;
        f.ok = f.ok && t.ok;
    }
    // Counts: non-finite samples (sum.w) and rays (sum_sq.w).
    f.px.w[6] = counts_add(store ? zero : px.w[6], sum.w, sum_sq.w);
    return f;
}

MCPT_NAMESPACE_END

#endif  // MCPT_GPU_FOLD_SUMS_H
