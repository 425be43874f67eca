// Exact sums for reproducible renders: each group's float sums (render_loop.h, group_spp) are
// added as 128-bit fixed-point integers, so the total is the same whatever the order and the
// grouping of the additions: chunks on several devices, MPI ranks, parts merged afterwards
// and a resumed checkpoint all give the image of one uninterrupted render, bit for bit.
#pragma once
#include <cmath>
#include <cstdint>

#if !defined(__SIZEOF_INT128__)
#error "mcpt needs a 64-bit compiler with __int128 (GCC or Clang)"
#endif

namespace mcpt {

using ExactSum = __int128;

// Fixed point with 50 fractional bits: steps of 8.9e-16 (radiance far below any image's
// precision), sums up to 2^76 (7.6e22: a squared radiance of 1e9 over 75,000 samples).
constexpr int kExactFractionBits = 50;
static_assert(kExactFractionBits == 50, "to_exact() scales by 0x1p50");

// A group's float sum as fixed point, truncated toward zero; false when it does not fit.
inline bool to_exact(float value, ExactSum& out) {
    const double x = double(value) * 0x1p50;  // exact: a power of two, far from overflow
    if (!(std::fabs(x) < 0x1p100)) return false;  // NaN, Inf or beyond any image
    out = std::fabs(x) < 0x1p62 ? ExactSum(int64_t(x)) : ExactSum(x);
    return true;
}

// The sum as a double, the same on every machine: the two halves converted (one rounding
// each), added (one rounding); the scalings by powers of two are exact (normal range: the
// sum is an integer), so a fused multiply-add gives the same bits.
inline double from_exact(ExactSum v) {
    static_assert(kExactFractionBits == 50, "the scale below is 0x1p-50");
    const double hi = double(int64_t(v >> 64)), lo = double(uint64_t(v));
    return (hi * 0x1p64 + lo) * 0x1p-50;
}

// Adds b to a; false when the sum would leave the range.
inline bool add_exact(ExactSum& a, ExactSum b) {
    const ExactSum s = ExactSum((unsigned __int128)a + (unsigned __int128)b);
    const int64_t hi = int64_t(s >> 64);
    if (hi >= (int64_t(1) << 62) || hi <= -(int64_t(1) << 62)) return false;  // 2^126 and beyond
    a = s;
    return true;
}

}  // namespace mcpt
