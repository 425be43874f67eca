// Low-discrepancy samples: Owen-scrambled Sobol points with hash-based scrambling
// (Burley, "Practical Hash-based Owen Scrambling", JCGT 2020), as a pure function of
// (pixel, sample index, dimension group, seed) like rng4(), so every backend draws the same
// stream. Each group of four dimensions shuffles the sample index with its own seed
// (Burley's padding), so groups are independent of each other while the first 2^k samples of
// a pixel stay an aligned block of Sobol points: dimensions 0 and 1 of every group form a
// (0,k,2)-net at every power of two, and each dimension alone is stratified.
#ifndef MCPT_GPU_SAMPLER_H
#define MCPT_GPU_SAMPLER_H

#include "rng.h"

MCPT_NAMESPACE_BEGIN

// Samples are shuffled within blocks of 2^16; each further block is scrambled anew.
#define SOBOL_BLOCK_BITS 16u

// The 32 bits of x in reverse order.
MCPT_FN uint reverse_bits(uint x) {
#if defined(MCPT_GLSL)
    return bitfieldReverse(x);
#elif defined(__clang__)
    return __builtin_bitreverse32(x);  // PoCL, clang C++
#elif defined(MCPT_NVIDIA_OPENCL)
    uint r;
    __asm__("brev.b32 %0, %1;" : "=r"(r) : "r"(x));  // one PTX instruction
    return r;
#else
    x = ((x >> 1u) & 0x55555555u) | ((x & 0x55555555u) << 1u);
    x = ((x >> 2u) & 0x33333333u) | ((x & 0x33333333u) << 2u);
    x = ((x >> 4u) & 0x0f0f0f0fu) | ((x & 0x0f0f0f0fu) << 4u);
    x = ((x >> 8u) & 0x00ff00ffu) | ((x & 0x00ff00ffu) << 8u);
    return (x >> 16u) | (x << 16u);
#endif
}

// Laine-Karras style permutation with Burley's constants: each bit flips as a hash of the
// bits below it (the seed picks the hash). For one value or, component by component, four.
#define LAINE_KARRAS_STEPS(x, seed) \
    x ^= x * 0x3d20adeau;           \
    x += seed;                      \
    x *= (seed >> 16u) | 1u;        \
    x ^= x * 0x05526c56u;           \
    x ^= x * 0x53a22864u
MCPT_FN uint laine_karras_permutation(uint x, uint seed) {
    LAINE_KARRAS_STEPS(x, seed);
    return x;
}
MCPT_FN uvec4 laine_karras_permutation4(uvec4 x, uvec4 seed) {
    LAINE_KARRAS_STEPS(x, seed);
    return x;
}
#undef LAINE_KARRAS_STEPS

// reverse_bits of each component; on CPU devices (MCPT_SAMPLER_VECTOR) in vector form, one
// instruction a step for all four (x86 has no bit reversal).
MCPT_FN uvec4 reverse_bits4(uvec4 x) {
#if defined(MCPT_GLSL)
    return bitfieldReverse(x);
#elif defined(MCPT_OPENCL) && defined(MCPT_SAMPLER_VECTOR)
    x = ((x >> 1u) & 0x55555555u) | ((x & 0x55555555u) << 1u);
    x = ((x >> 2u) & 0x33333333u) | ((x & 0x33333333u) << 2u);
    x = ((x >> 4u) & 0x0f0f0f0fu) | ((x & 0x0f0f0f0fu) << 4u);
    x = ((x >> 8u) & 0x00ff00ffu) | ((x & 0x00ff00ffu) << 8u);
    return (x >> 16u) | (x << 16u);
#else
    return UV4(reverse_bits(x.x), reverse_bits(x.y), reverse_bits(x.z), reverse_bits(x.w));
#endif
}

// Owen scrambling of a 32-bit fixed-point value: each bit flips as a hash of the bits above it.
MCPT_FN uint nested_uniform_scramble(uint x, uint seed) {
    return reverse_bits(laine_karras_permutation(reverse_bits(x), seed));
}

// Sobol point `index` (< 2^SOBOL_BLOCK_BITS) in dimensions 0 to 3, as 32-bit fixed point
// with the bits reversed (bit 0 the most significant digit), the order Owen scrambling works
// in. Dimension 0 is the index itself (van der Corput); each line below adds the reversed
// direction numbers of dimensions 1, 2 and 3 for one bit of the index: primitive polynomials
// x + 1, x^2 + x + 1 and x^3 + x + 1 with initial m = (1), (1, 3), (1, 3, 1) (Joe & Kuo 2008;
// sampler_test.cpp derives them again). Written out, not a table: constants need no memory,
// and no lane diverges.
#define SOBOL_BIT(bit, v1, v2, v3)     \
    take = 0u - ((index >> bit) & 1u); \
    x ^= UV4(0u, v1, v2, v3) & UV4(take, take, take, take)
MCPT_FN uvec4 sobol4_reversed(uint index) {
    uvec4 x = UV4(index, 0u, 0u, 0u);
    uint take;
    // clang-format off
    SOBOL_BIT( 0u, 0x00000001u, 0x00000001u, 0x00000001u);
    SOBOL_BIT( 1u, 0x00000003u, 0x00000003u, 0x00000003u);
    SOBOL_BIT( 2u, 0x00000005u, 0x00000006u, 0x00000004u);
    SOBOL_BIT( 3u, 0x0000000fu, 0x00000009u, 0x0000000au);
    SOBOL_BIT( 4u, 0x00000011u, 0x00000017u, 0x0000001fu);
    SOBOL_BIT( 5u, 0x00000033u, 0x0000003au, 0x0000002eu);
    SOBOL_BIT( 6u, 0x00000055u, 0x00000071u, 0x00000045u);
    SOBOL_BIT( 7u, 0x000000ffu, 0x000000a3u, 0x000000c9u);
    SOBOL_BIT( 8u, 0x00000101u, 0x00000116u, 0x0000011bu);
    SOBOL_BIT( 9u, 0x00000303u, 0x00000339u, 0x000002a4u);
    SOBOL_BIT(10u, 0x00000505u, 0x00000677u, 0x0000079au);
    SOBOL_BIT(11u, 0x00000f0fu, 0x000009aau, 0x00000b67u);
    SOBOL_BIT(12u, 0x00001111u, 0x00001601u, 0x0000101eu);
    SOBOL_BIT(13u, 0x00003333u, 0x00003903u, 0x0000302du);
    SOBOL_BIT(14u, 0x00005555u, 0x00007706u, 0x00004041u);
    SOBOL_BIT(15u, 0x0000ffffu, 0x0000aa09u, 0x0000a0c3u);
    // clang-format on
    return x;
}
#undef SOBOL_BIT

// Four uniforms in [0, 1) for dimension group `group` of sample `sample_index` of `pixel`.
// Called, not inlined, on CPU devices (platform.h: MCPT_FN_CALLED).
MCPT_FN_CALLED vec4 sobol4(uint pixel, uint sample_index, uint group, uint seed) {
    // Seeds for this pixel, group, seed and block of samples: one for the index, four for
    // the dimensions.
    uvec4 h = pcg4d(UV4(pixel, group, seed, sample_index >> SOBOL_BLOCK_BITS));
    uvec4 s = pcg4d(h);
    // Shuffle the index within its block by Owen scrambling (the first 2^k samples stay an
    // aligned block of 2^k Sobol points): bits above the block come out constant, masked off.
    uint block_mask = (1u << SOBOL_BLOCK_BITS) - 1u;
    uint index = nested_uniform_scramble(sample_index & block_mask, h.x) & block_mask;
    // The point, Owen-scrambled per dimension in reversed order, then turned back.
    uvec4 x = reverse_bits4(laine_karras_permutation4(sobol4_reversed(index), s));
    vec4 u;
    u.x = uint_to_unit_float(x.x);
    u.y = uint_to_unit_float(x.y);
    u.z = uint_to_unit_float(x.z);
    u.w = uint_to_unit_float(x.w);
    return u;
}

MCPT_NAMESPACE_END

#endif  // MCPT_GPU_SAMPLER_H
