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

// The 32 bits of x in reverse order: by hardware where there is an instruction, else by
// swapping ever larger groups of bits (for one value or, component by component, four).
#define REVERSE_BITS_STEPS(x)                                  \
    x = ((x >> 1u) & 0x55555555u) | ((x & 0x55555555u) << 1u); \
    x = ((x >> 2u) & 0x33333333u) | ((x & 0x33333333u) << 2u); \
    x = ((x >> 4u) & 0x0f0f0f0fu) | ((x & 0x0f0f0f0fu) << 4u); \
    x = ((x >> 8u) & 0x00ff00ffu) | ((x & 0x00ff00ffu) << 8u); \
    return (x >> 16u) | (x << 16u)
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
    REVERSE_BITS_STEPS(x);
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
    REVERSE_BITS_STEPS(x);
#else
    return UV4(reverse_bits(x.x), reverse_bits(x.y), reverse_bits(x.z), reverse_bits(x.w));
#endif
}
#undef REVERSE_BITS_STEPS

// Owen scrambling of a 32-bit fixed-point value: each bit flips as a hash of the bits above it.
MCPT_FN uint nested_uniform_scramble(uint x, uint seed) {
    return reverse_bits(laine_karras_permutation(reverse_bits(x), seed));
}

// Sobol point `index` (< 2^SOBOL_BLOCK_BITS) in dimensions 0 to 3, as 32-bit fixed point
// with the bits reversed (bit 0 the most significant digit), the order Owen scrambling works
// in. Dimension 0 is the index itself (van der Corput); dimensions 1, 2 and 3 add, for each
// bit of the index, their reversed direction numbers: primitive polynomials x + 1, x^2 + x + 1
// and x^3 + x + 1 with initial m = (1), (1, 3), (1, 3, 1) (Joe & Kuo 2008; sampler_test.cpp
// derives them again). SOBOL_COLUMNS_k: index bits 4k to 4k + 3, each as (v1, v2, v3).
// clang-format off
#define SOBOL_COLUMNS_0 0x00000001u, 0x00000001u, 0x00000001u,  0x00000003u, 0x00000003u, 0x00000003u, \
                        0x00000005u, 0x00000006u, 0x00000004u,  0x0000000fu, 0x00000009u, 0x0000000au
#define SOBOL_COLUMNS_1 0x00000011u, 0x00000017u, 0x0000001fu,  0x00000033u, 0x0000003au, 0x0000002eu, \
                        0x00000055u, 0x00000071u, 0x00000045u,  0x000000ffu, 0x000000a3u, 0x000000c9u
#define SOBOL_COLUMNS_2 0x00000101u, 0x00000116u, 0x0000011bu,  0x00000303u, 0x00000339u, 0x000002a4u, \
                        0x00000505u, 0x00000677u, 0x0000079au,  0x00000f0fu, 0x000009aau, 0x00000b67u
#define SOBOL_COLUMNS_3 0x00001111u, 0x00001601u, 0x0000101eu,  0x00003333u, 0x00003903u, 0x0000302du, \
                        0x00005555u, 0x00007706u, 0x00004041u,  0x0000ffffu, 0x0000aa09u, 0x0000a0c3u
// clang-format on
#if defined(MCPT_OPENCL) && defined(MCPT_SAMPLER_VECTOR)
// CPU devices: the sum of each nibble's columns from a table of 16 entries a nibble (1 KiB),
// four loads instead of sixteen steps.
#define SOBOL_XOR4(n, a, b, c, d) \
    (((n)&1u ? (a) : 0u) ^ ((n)&2u ? (b) : 0u) ^ ((n)&4u ? (c) : 0u) ^ ((n)&8u ? (d) : 0u))
#define SOBOL_ENTRY_(n, a1, a2, a3, b1, b2, b3, c1, c2, c3, d1, d2, d3)       \
    (uint4)(0u, SOBOL_XOR4(n, a1, b1, c1, d1), SOBOL_XOR4(n, a2, b2, c2, d2), \
            SOBOL_XOR4(n, a3, b3, c3, d3))
#define SOBOL_NIBBLE(...)                                                                        \
    SOBOL_ENTRY_(0u, __VA_ARGS__), SOBOL_ENTRY_(1u, __VA_ARGS__), SOBOL_ENTRY_(2u, __VA_ARGS__), \
        SOBOL_ENTRY_(3u, __VA_ARGS__), SOBOL_ENTRY_(4u, __VA_ARGS__),                            \
        SOBOL_ENTRY_(5u, __VA_ARGS__), SOBOL_ENTRY_(6u, __VA_ARGS__),                            \
        SOBOL_ENTRY_(7u, __VA_ARGS__), SOBOL_ENTRY_(8u, __VA_ARGS__),                            \
        SOBOL_ENTRY_(9u, __VA_ARGS__), SOBOL_ENTRY_(10u, __VA_ARGS__),                           \
        SOBOL_ENTRY_(11u, __VA_ARGS__), SOBOL_ENTRY_(12u, __VA_ARGS__),                          \
        SOBOL_ENTRY_(13u, __VA_ARGS__), SOBOL_ENTRY_(14u, __VA_ARGS__),                          \
        SOBOL_ENTRY_(15u, __VA_ARGS__)
__constant uint4 SOBOL_NIBBLES[64] = {SOBOL_NIBBLE(SOBOL_COLUMNS_0), SOBOL_NIBBLE(SOBOL_COLUMNS_1),
                                      SOBOL_NIBBLE(SOBOL_COLUMNS_2), SOBOL_NIBBLE(SOBOL_COLUMNS_3)};
#undef SOBOL_NIBBLE
#undef SOBOL_ENTRY_
#undef SOBOL_XOR4
MCPT_FN uvec4 sobol4_reversed(uint index) {
    return UV4(index, 0u, 0u, 0u) ^ SOBOL_NIBBLES[index & 15u] ^
           SOBOL_NIBBLES[16u + ((index >> 4u) & 15u)] ^ SOBOL_NIBBLES[32u + ((index >> 8u) & 15u)] ^
           SOBOL_NIBBLES[48u + ((index >> 12u) & 15u)];
}
#else
// GPUs: written out, not a table (constants need no memory, and no lane diverges).
#define SOBOL_BIT(bit, v1, v2, v3)       \
    take = 0u - ((index >> (bit)) & 1u); \
    x ^= UV4(0u, v1, v2, v3) & UV4(take, take, take, take);
#define SOBOL_NIBBLE_(k, a1, a2, a3, b1, b2, b3, c1, c2, c3, d1, d2, d3) \
    SOBOL_BIT(4u * (k), a1, a2, a3)                                      \
    SOBOL_BIT(4u * (k) + 1u, b1, b2, b3)                                 \
    SOBOL_BIT(4u * (k) + 2u, c1, c2, c3)                                 \
    SOBOL_BIT(4u * (k) + 3u, d1, d2, d3)
#define SOBOL_NIBBLE(k, columns) SOBOL_NIBBLE_(k, columns)
MCPT_FN uvec4 sobol4_reversed(uint index) {
    uvec4 x = UV4(index, 0u, 0u, 0u);
    uint take;
    SOBOL_NIBBLE(0u, SOBOL_COLUMNS_0)
    SOBOL_NIBBLE(1u, SOBOL_COLUMNS_1)
    SOBOL_NIBBLE(2u, SOBOL_COLUMNS_2)
    SOBOL_NIBBLE(3u, SOBOL_COLUMNS_3)
    return x;
}
#undef SOBOL_NIBBLE
#undef SOBOL_NIBBLE_
#undef SOBOL_BIT
#endif
#undef SOBOL_COLUMNS_0
#undef SOBOL_COLUMNS_1
#undef SOBOL_COLUMNS_2
#undef SOBOL_COLUMNS_3

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
