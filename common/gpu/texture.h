// Texture fetches and per-vertex data, decoded the same way in OpenCL C, GLSL and C++ from
// plain words (no samplers or image objects, so both APIs filter bit for bit alike): half
// floats, octahedral normals, bilinear filtering with glTF's wrap modes.
#ifndef MCPT_GPU_TEXTURE_H
#define MCPT_GPU_TEXTURE_H

#include "sampling.h"
#include "scene_access.h"

MCPT_NAMESPACE_BEGIN

// IEEE half (low 16 bits of h) to float; textures hold finite halves only.
MCPT_FN float half_to_float(uint h) {
    uint sign = (h & 0x8000u) << 16u;
    uint e = (h >> 10u) & 0x1fu;
    uint m = h & 0x3ffu;
    if (e == 0u) {
        float v = F32(m) * 5.9604645e-8f;  // 2^-24: subnormal
        return sign != 0u ? -v : v;
    }
    return uint_as_float(sign | ((e + 112u) << 23u) | (m << 13u));
}

// A signed 16-bit integer in [-32767, 32767] to [-1, 1] (snorm16).
MCPT_FN float snorm16(uint bits) {
    int v = I32(bits << 16u) >> 16;
    return MAXF(F32(v) * (1.0f / 32767.0f), -1.0f);
}

// A unit vector from its octahedral encoding (x in the low, y in the high 16 bits).
MCPT_FN vec3 normal_from_oct(uint w) {
    float x = snorm16(w & 0xffffu);
    float y = snorm16(w >> 16u);
    float z = 1.0f - ABSF(x) - ABSF(y);
    if (z < 0.0f) {
        float ox = x;
        x = (1.0f - ABSF(y)) * (ox >= 0.0f ? 1.0f : -1.0f);
        y = (1.0f - ABSF(ox)) * (y >= 0.0f ? 1.0f : -1.0f);
    }
    return normalize(V3(x, y, z));
}

// A texel coordinate (|i| <= 2^24) wrapped into [0, size) by glTF's wrap mode. Remainders are
// taken of non-negative values (GLSL leaves % of negative integers undefined).
MCPT_FN uint wrap_texel(int i, uint size, uint mode) {
    if (mode == TEXTURE_WRAP_CLAMP) return U32(clamp(i, 0, I32(size) - 1));
    uint period = mode == TEXTURE_WRAP_MIRROR ? 2u * size : size;
    uint k = U32(i + I32(period * (16777216u / period + 1u))) % period;
    return k < size ? k : period - 1u - k;
}

// wrap_texel of i and of i + 1 (a bilinear fetch's two columns or rows), from one remainder:
// the integer division and remainder cost a GPU a few dozen instructions each.
MCPT_FN uvec2 wrap_texel_pair(int i, uint size, uint mode) {
    if (mode == TEXTURE_WRAP_CLAMP)
        return UV2(U32(clamp(i, 0, I32(size) - 1)), U32(clamp(i + 1, 0, I32(size) - 1)));
    uint period = mode == TEXTURE_WRAP_MIRROR ? 2u * size : size;
    uint k = U32(i + I32(period * (16777216u / period + 1u))) % period;
    uint k1 = k + 1u == period ? 0u : k + 1u;
    return UV2(k < size ? k : period - 1u - k, k1 < size ? k1 : period - 1u - k1);
}

MCPT_FN vec4 texel_rgba(SCENE_PARAMS_ GpuTexture t, uint x, uint y) {
#ifdef MCPT_NEGATIVE_CONTROL_TEXEL_SHIFT
    x = min(x + 1u, t.width - 1u);  // tests: every read one texel to the right
#endif
    uint i = t.offset / 2u + y * t.width + x;
    // The devices' own conversions (exact for finite halves, as half_to_float): one
    // instruction a channel instead of half_to_float's dozen and its branch, inlined at each
    // fetch (NVIDIA: the textured scene's kernel stalls on instruction fetch).
#if defined(MCPT_GLSL)
    uvec2 w = TEXEL(i);
    return vec4(unpackHalf2x16(w.x), unpackHalf2x16(w.y));
#elif defined(MCPT_OPENCL)
    return vload_half4(i, (MCPT_CONST_BUF half*)texels);
#else
    uvec2 w = TEXEL(i);
    return V4(half_to_float(w.x & 0xffffu), half_to_float(w.x >> 16u), half_to_float(w.y & 0xffffu),
              half_to_float(w.y >> 16u));
#endif
}

// Texture `index` at (u, v): bilinear between the four nearest texel centers (or the nearest
// texel), wrapped per axis.
MCPT_FN vec4 sample_texture(SCENE_PARAMS_ uint index, vec2 uv) {
    GpuTexture t = TEXTURE(index);
    uint wrap_s = t.flags & 3u, wrap_t = (t.flags >> 2u) & 3u;
    // Texel space; keep the integer part small so that floats stay exact for tiled UVs.
    float fx = uv.x * F32(t.width) - 0.5f;
    float fy = uv.y * F32(t.height) - 0.5f;
    fx = clamp(fx, -16777216.0f, 16777216.0f);
    fy = clamp(fy, -16777216.0f, 16777216.0f);
    if ((t.flags & TEXTURE_NEAREST) != 0u) {
        uint x = wrap_texel(I32(floor(fx + 0.5f)), t.width, wrap_s);
        uint y = wrap_texel(I32(floor(fy + 0.5f)), t.height, wrap_t);
        return texel_rgba(SCENE_ARGS_ t, x, y);
    }
    float x0f = floor(fx), y0f = floor(fy);
    float ax = fx - x0f, ay = fy - y0f;
    int x0 = I32(x0f), y0 = I32(y0f);
    uvec2 xs = wrap_texel_pair(x0, t.width, wrap_s), ys = wrap_texel_pair(y0, t.height, wrap_t);
    uint xa = xs.x, xb = xs.y, ya = ys.x, yb = ys.y;
    vec4 top =
        texel_rgba(SCENE_ARGS_ t, xa, ya) * (1.0f - ax) + texel_rgba(SCENE_ARGS_ t, xb, ya) * ax;
    vec4 bottom =
        texel_rgba(SCENE_ARGS_ t, xa, yb) * (1.0f - ax) + texel_rgba(SCENE_ARGS_ t, xb, yb) * ax;
    return top * (1.0f - ay) + bottom * ay;
}

// A material with its textures applied at uv (factors times texels, as glTF), and its normal
// texture's texel there (for normal_mapped).
MCPT_STRUCT(TexturedMaterial) {
    GpuMaterial m;
    vec4 normal_texel;
};

// A GGX alpha whose perceptual roughness (sqrt alpha) a texel scales, as glTF scales roughness.
MCPT_FN float alpha_scaled(float alpha, float factor) {
    float roughness = sqrt(alpha) * factor;
    return MAXF(roughness * roughness, MIN_GGX_ALPHA);
}

// One fetch in a loop kept rolled over the four maps (eight with the layers' halves), not one
// inlined copy of sample_texture() a map (code size: NVIDIA's Vulkan inlines every call).
MCPT_FN TexturedMaterial textured_material(SCENE_PARAMS_ GpuMaterial m, vec2 uv) {
    TexturedMaterial r;
    r.normal_texel = V4S(0.0f);
    uint maps = HAS_FEATURE(FEATURE_CLEARCOAT | FEATURE_SHEEN) ? 8u : 4u;
    NO_UNROLL
    for (uint k = 0u; k < maps; ++k) {
        uint tex = k == 0u
                       ? m.tex_base
                       : (k == 1u ? m.tex_metal_rough : (k == 2u ? m.tex_emission : m.tex_normal));
        if (k >= 4u) {
            uint word = k < 6u ? m.tex_clearcoat : m.tex_sheen;
            tex = (k & 1u) == 0u ? (word & 0xffffu) : (word >> 16u);
            if (tex == NO_TEXTURE16) continue;
        }
        if (tex == NO_TEXTURE || (k == 3u && !HAS_FEATURE(FEATURE_SHADING_NORMALS))) continue;
        vec4 t = sample_texture(SCENE_ARGS_ tex, uv);
        if (k == 0u) {
            m.r *= t.x;
            m.g *= t.y;
            m.b *= t.z;
        } else if (k == 1u) {
            m.metallic *= t.z;
            m.alpha = alpha_scaled(m.alpha, t.y);
        } else if (k == 2u) {
            m.er *= t.x;
            m.eg *= t.y;
            m.eb *= t.z;
        } else if (k == 3u) {
            r.normal_texel = t;
        } else if (k == 4u) {
            m.clearcoat *= t.x;
        } else if (k == 5u) {
            m.clearcoat_alpha = alpha_scaled(m.clearcoat_alpha, t.y);
        } else if (k == 6u) {
            m.sheen_r *= t.x;
            m.sheen_g *= t.y;
            m.sheen_b *= t.z;
        } else {
            m.sheen_roughness = MAXF(m.sheen_roughness * t.w, MIN_SHEEN_ROUGHNESS);
        }
    }
    r.m = m;
    return r;
}

// The shading normal ns bent by a tangent-space normal texture's texel c; the tangent follows
// u, the bitangent points up the image (toward -v), as glTF's normal textures expect.
MCPT_FN vec3 normal_mapped(vec4 c, vec3 ns, vec3 dpdu, vec3 dpdv) {
    vec3 t = dpdu - ns * dot(ns, dpdu);
    float len = length(t);
    if (!(len > 0.0f)) return ns;
    t = DIVF(t, len);
    vec3 b = cross(ns, t);
    if (dot(b, dpdv) > 0.0f) b = -b;
    vec3 m = t * (2.0f * c.x - 1.0f) + b * (2.0f * c.y - 1.0f) + ns * (2.0f * c.z - 1.0f);
    float ml = length(m);
    return ml > 0.0f ? DIVF(m, ml) : ns;
}

// Whether triangle `tri` of material `material` is there at (b1, b2) under alphaMode MASK: the
// base alpha (texture, or 1) against the cutoff, which holds cutoff / alpha factor (0: opaque).
// Reads the two fields it needs, not the material (this runs inside the traversal).
MCPT_FN bool opaque_at(SCENE_PARAMS_ uint material, uint tri, float b1, float b2) {
    float cutoff = MATERIAL(material).alpha_cutoff;
    if (!(cutoff > 0.0f)) return true;
    float a = 1.0f;
    uint tex = MATERIAL(material).tex_base;
    if (HAS_FEATURE(FEATURE_TEXTURES) && tex != NO_TEXTURE) {
        vec2 uv = V2(0.0f, 0.0f);
        if ((PARAM(scene_flags) & SCENE_VERTEX_DATA) != 0u) {
            GpuTriangleAttributes at = ATTRIBUTES(tri);
            float b0 = 1.0f - b1 - b2;
            uv = V2(at.u0, at.v0) * b0 + V2(at.u1, at.v1) * b1 + V2(at.u2, at.v2) * b2;
        }
        a = sample_texture(SCENE_ARGS_ tex, uv).w;
    }
    return a >= cutoff;
}

MCPT_NAMESPACE_END

#endif  // MCPT_GPU_TEXTURE_H
