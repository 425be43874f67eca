// How device functions reach the scene buffers. OpenCL C and C++ pass them as arguments
// (SCENE_PARAMS_ in declarations, SCENE_ARGS_ in calls, both ending with a comma); GLSL
// declares them once as storage blocks at the binding slots of shared_types.h.
#ifndef MCPT_GPU_SCENE_ACCESS_H
#define MCPT_GPU_SCENE_ACCESS_H

#include "shared_types.h"

MCPT_NAMESPACE_BEGIN
// A triangle from its five 8-byte words: GLSL and OpenCL on GPUs read triangles as 64-bit
// words, five loads instead of ten 32-bit ones (NVIDIA: up to 1.2x on triangle-heavy scenes).
MCPT_FN GpuTriangle triangle_from_words(uvec2 a, uvec2 b, uvec2 c, uvec2 d, uvec2 e) {
    GpuTriangle t;
    t.v0x = uint_as_float(a.x);
    t.v0y = uint_as_float(a.y);
    t.v0z = uint_as_float(b.x);
    t.v1x = uint_as_float(b.y);
    t.v1y = uint_as_float(c.x);
    t.v1z = uint_as_float(c.y);
    t.v2x = uint_as_float(d.x);
    t.v2y = uint_as_float(d.y);
    t.v2z = uint_as_float(e.x);
    t.material = e.y;
    return t;
}
MCPT_NAMESPACE_END

#if defined(MCPT_GLSL)
layout(std140, binding = BINDING_PARAMS) uniform ParamsBlock { GpuParams params; };
// The shared buffers of shared_types.h, each declared once per element type (aliases).
layout(std430, binding = BINDING_TREE) readonly buffer NodesBlock { KdNode nodes[]; };
layout(std430, binding = BINDING_TREE) readonly buffer TreeWordsBlock { uint tree_words[]; };
// BVH nodes as 16-byte quads (traverse_bvh.h).
layout(std430, binding = BINDING_TREE) readonly buffer BvhBlock { uvec4 bvh_quads[]; };
// Triangles as 8-byte words (triangle_from_words).
layout(std430, binding = BINDING_TRIANGLES) readonly buffer TriBlock { uvec2 triangle_words[]; };
layout(std430, binding = BINDING_SHADING) readonly buffer SphereBlock { GpuSphere spheres[]; };
layout(std430, binding = BINDING_SHADING) readonly buffer MatBlock { GpuMaterial shading_materials[]; };
layout(std430, binding = BINDING_SHADING) readonly buffer LightBlock { GpuLight shading_lights[]; };
#if defined(MCPT_SCENE_TEXELS)
// The SPIR-V module for CPU devices reads the tree, triangles and shading data through
// texel-buffer views of the same buffers (shared_types.h): k-d nodes and triangles as word
// pairs; BVH nodes (fourteen), spheres (two), materials (six) and lights (one) as 16-byte
// texels.
layout(binding = BINDING_TREE_TEXELS) uniform usamplerBuffer tree_texels;
layout(binding = BINDING_TRIANGLE_TEXELS) uniform usamplerBuffer triangle_quads;
layout(binding = BINDING_SHADING_TEXELS) uniform usamplerBuffer shading_quads;
KdNode load_node(uint i) {
    uvec2 w = texelFetch(tree_texels, int(i)).xy;
    return KdNode(w.x, w.y);
}
// The tree's texels are word pairs for a k-d tree, quads for a BVH (vulkan/vk_backend.cpp).
uint load_leaf_index(uint i) {
    if ((params.scene_flags & SCENE_BVH) != 0u)
        return texelFetch(tree_texels, int(params.num_nodes / 2u + (i >> 2u)))[i & 3u];
    uvec2 w = texelFetch(tree_texels, int(params.num_nodes + (i >> 1u))).xy;
    return (i & 1u) != 0u ? w.y : w.x;
}
GpuSphere load_sphere(uint i) {
    uvec4 a = texelFetch(shading_quads, int(2u * i));
    uint material = texelFetch(shading_quads, int(2u * i + 1u)).x;
    return GpuSphere(uintBitsToFloat(a.x), uintBitsToFloat(a.y), uintBitsToFloat(a.z),
                     uintBitsToFloat(a.w), material, 0u, 0u, 0u);
}
GpuMaterial load_material(uint i) {
    int t = int(SHADING_MATERIALS_WORD(params.num_spheres) / 4u + (MATERIAL_WORDS / 4u) * i);
    uvec4 a = texelFetch(shading_quads, t), b = texelFetch(shading_quads, t + 1);
    uvec4 c = texelFetch(shading_quads, t + 2), d = texelFetch(shading_quads, t + 3);
    // (The layers' two texels go unread, and their fetches with them, in builds without.)
    uvec4 e = texelFetch(shading_quads, t + 4), f = texelFetch(shading_quads, t + 5);
    return GpuMaterial(uintBitsToFloat(a.x), uintBitsToFloat(a.y), uintBitsToFloat(a.z), a.w,
                       uintBitsToFloat(b.x), uintBitsToFloat(b.y), uintBitsToFloat(b.z),
                       uintBitsToFloat(b.w), uintBitsToFloat(c.x), uintBitsToFloat(c.y),
                       uintBitsToFloat(c.z), uintBitsToFloat(c.w), d.x, d.y, d.z, d.w,
                       uintBitsToFloat(e.x), uintBitsToFloat(e.y), uintBitsToFloat(e.z),
                       uintBitsToFloat(e.w), uintBitsToFloat(f.x), uintBitsToFloat(f.y), f.z, f.w);
}
GpuLight load_light(uint i) {
    uint w = SHADING_LIGHTS_WORD(params.num_spheres, params.num_materials);
    uvec4 a = texelFetch(shading_quads, int(w / 4u + i));
    return GpuLight(a.x, a.y, uintBitsToFloat(a.z), uintBitsToFloat(a.w));
}
#define NODE(i) load_node(i)
#define LEAF_INDEX(i) load_leaf_index(i)
// A BVH quad: one texel of the tree (lavapipe: +4 to +12% against the storage buffer's quads
// on bunny, dragon-48k and the textured scene, with two word-pair texels a quad).
uvec4 load_bvh_quad(uint i) { return texelFetch(tree_texels, int(i)); }
#define BVH_QUAD(i) load_bvh_quad(i)
// Word pair w of the triangle buffer: half of a 16-byte texel.
uvec2 triangle_word(uint w) {
    uvec4 q = texelFetch(triangle_quads, int(w >> 1u));
    return (w & 1u) != 0u ? q.zw : q.xy;
}
#define TRIANGLE_WORD(w) triangle_word(w)
#define SPHERE(i) load_sphere(i)
#define MATERIAL(i) load_material(i)
#define LIGHT(i) load_light(i)
#else
#define NODE(i) nodes[i]
#define BVH_QUAD(i) bvh_quads[i]
#define LEAF_INDEX(i) tree_words[2u * params.num_nodes + (i)]
#define TRIANGLE_WORD(w) triangle_words[w]
#define SPHERE(i) spheres[i]
#define MATERIAL(i) \
    shading_materials[SHADING_MATERIALS_WORD(params.num_spheres) / MATERIAL_WORDS + (i)]
#define LIGHT(i) shading_lights[SHADING_LIGHTS_WORD(params.num_spheres, params.num_materials) / 4u + (i)]
#endif
// Traversal stack entries, from the tree depth, and the scene's features (specialization
// constants; id 1 is the workgroup size).
layout(constant_id = 0) const uint KD_STACK_SIZE = 64u;
layout(constant_id = 2) const uint MCPT_FEATURES = FEATURE_ALL;
layout(constant_id = 3) const uint KD_NODE_STEPS = 1u;  // traverse.h
layout(constant_id = 4) const uint KD_TRI_STEPS = 1u;
layout(constant_id = 5) const uint KD_OVERLAP = 1u;  // traverse.h
layout(constant_id = 6) const uint ENV_STRATEGY_SPEC = 0u;  // integrator.h (tests)
layout(constant_id = 7) const uint MCPT_TRACE_SITES = 2u;   // integrator.h: step_path()
layout(constant_id = 8) const uint MCPT_WALK_STEPS = 0u;    // integrator.h: step_slot_walk()
#define MCPT_CARRIED_SHADOW 1  // the path can carry a shadow ray (with one trace site)
#define MCPT_CARRIED_RECEIVER 1  // the path carries the receiver's normal (light tree)
#define MCPT_CARRIED_MEDIUM 1    // ... and the absorbing glass it is inside (FEATURE_VOLUME)
#define MCPT_ENV_STRATEGY ENV_STRATEGY_SPEC
#define SCENE_PARAMS_
#define SCENE_ARGS_
#define PARAM(x) params.x
GpuTriangle load_triangle(uint i) {
    uint w = 5u * i;
#if defined(MCPT_SCENE_TEXELS)
    // Three 16-byte texels instead of five fetches: an odd triangle starts mid-texel.
    int q = int(w >> 1u);
    uvec4 a = texelFetch(triangle_quads, q), b = texelFetch(triangle_quads, q + 1);
    uvec4 c = texelFetch(triangle_quads, q + 2);
    if ((i & 1u) != 0u)
        return triangle_from_words(a.zw, b.xy, b.zw, c.xy, c.zw);
    return triangle_from_words(a.xy, a.zw, b.xy, b.zw, c.xy);
#else
    return triangle_from_words(TRIANGLE_WORD(w), TRIANGLE_WORD(w + 1u), TRIANGLE_WORD(w + 2u),
                               TRIANGLE_WORD(w + 3u), TRIANGLE_WORD(w + 4u));
#endif
}
#define TRIANGLE(i) load_triangle(i)
// Per-vertex data after the triangles, textures after the lights (shared_types.h).
GpuTriangleAttributes load_attributes(uint i) {
    uint w = 5u * (params.num_triangles + i);
    uvec2 a = TRIANGLE_WORD(w), b = TRIANGLE_WORD(w + 1u), c = TRIANGLE_WORD(w + 2u);
    uvec2 d = TRIANGLE_WORD(w + 3u), e = TRIANGLE_WORD(w + 4u);
    return GpuTriangleAttributes(a.x, a.y, b.x, b.y, uintBitsToFloat(c.x), uintBitsToFloat(c.y),
                                 uintBitsToFloat(d.x), uintBitsToFloat(d.y),
                                 uintBitsToFloat(e.x), uintBitsToFloat(e.y));
}
#define ATTRIBUTES(i) load_attributes(i)
layout(std430, binding = BINDING_SHADING) readonly buffer TextureBlock { GpuTexture shading_textures[]; };
layout(std430, binding = BINDING_SHADING) readonly buffer TexelBlock { uvec2 shading_texels[]; };
#define TEXTURE(i) shading_textures[SHADING_LIGHTS_WORD(params.num_spheres, params.num_materials) / 4u + params.num_lights + (i)]
#define TEXEL(i) shading_texels[params.texels_word / 2u + (i)]
// Words and 16-byte groups after texels_word (punctual lights and the environment, lights.h;
// a group starts on a multiple of 4 words from the buffer's start).
layout(std430, binding = BINDING_SHADING) readonly buffer WordBlock { uint shading_words[]; };
layout(std430, binding = BINDING_SHADING) readonly buffer Vec4Block { vec4 shading_vec4[]; };
#define SCENE_WORD(w) shading_words[params.texels_word + (w)]
#define SCENE_VEC4(w) shading_vec4[(params.texels_word + (w)) / 4u]
#else
#if defined(MCPT_CPP)
#define MCPT_UNUSED [[maybe_unused]]
#else
#define MCPT_UNUSED
#endif
#define SCENE_PARAMS_                                                                          \
    MCPT_UNUSED MCPT_CONST_BUF GpuParams *params, MCPT_UNUSED MCPT_CONST_BUF KdNode *nodes,    \
        MCPT_UNUSED MCPT_CONST_BUF uint *leaf_indices,                                         \
        MCPT_UNUSED MCPT_CONST_BUF GpuTriangle *triangles,                                     \
        MCPT_UNUSED MCPT_CONST_BUF GpuSphere *spheres,                                         \
        MCPT_UNUSED MCPT_CONST_BUF GpuMaterial *materials,                                     \
        MCPT_UNUSED MCPT_CONST_BUF GpuLight *lights,                                           \
        MCPT_UNUSED MCPT_CONST_BUF GpuTriangleAttributes *attributes,                          \
        MCPT_UNUSED MCPT_CONST_BUF GpuTexture *textures, MCPT_UNUSED MCPT_CONST_BUF uint *texels,
#define SCENE_ARGS_ \
    params, nodes, leaf_indices, triangles, spheres, materials, lights, attributes, textures, texels,
#define PARAM(x) params->x
#define NODE(i) nodes[i]
// BVH nodes as 16-byte quads of the tree buffer (traverse_bvh.h).
#if defined(MCPT_OPENCL)
#define BVH_QUAD(i) (((__global const uint4*)nodes)[i])
#else
#define BVH_QUAD(i) bvh_quad(reinterpret_cast<const uint*>(nodes), i)
MCPT_NAMESPACE_BEGIN
inline uvec4 bvh_quad(const uint* words, uint i) {
    return uvec4(words[4u * i], words[4u * i + 1u], words[4u * i + 2u], words[4u * i + 3u]);
}
MCPT_NAMESPACE_END
#endif
#define LEAF_INDEX(i) leaf_indices[i]
#define SPHERE(i) spheres[i]
#define MATERIAL(i) materials[i]
#define LIGHT(i) lights[i]
#define ATTRIBUTES(i) attributes[i]
#define TEXTURE(i) textures[i]
#define SCENE_WORD(w) texels[w]
#if defined(MCPT_OPENCL)
#define TEXEL(i) vload2(i, texels)
#define SCENE_VEC4(w) as_float4(vload4(0, texels + (w)))
#else
#define TEXEL(i) uvec2(texels[2u * (i)], texels[2u * (i) + 1u])
#define SCENE_VEC4(w)                                                                 \
    vec4(uint_as_float(texels[w]), uint_as_float(texels[(w) + 1u]),                   \
         uint_as_float(texels[(w) + 2u]), uint_as_float(texels[(w) + 3u]))
#endif
// OpenCL on GPUs reads words too (-DMCPT_TRIANGLE_WORDS); PoCL's CPU code is 6-11% faster
// with the plain struct read (measured with mcpt compare --b-defines).
#if defined(MCPT_OPENCL) && defined(MCPT_TRIANGLE_WORDS)
MCPT_FN GpuTriangle load_triangle(__global const GpuTriangle* triangles, uint i) {
    __global const uint2* w = (__global const uint2*)triangles + 5u * i;
    return triangle_from_words(w[0], w[1], w[2], w[3], w[4]);
}
#define TRIANGLE(i) load_triangle(triangles, i)
#else
#define TRIANGLE(i) triangles[i]
#endif
#ifndef KD_STACK_SIZE
#define KD_STACK_SIZE 64u  // OpenCL builds pass -DKD_STACK_SIZE from the tree depth
#endif
#ifndef MCPT_FEATURES
#define MCPT_FEATURES FEATURE_ALL  // OpenCL builds pass -DMCPT_FEATURES from the scene
#endif
#ifndef KD_NODE_STEPS
#define KD_NODE_STEPS 1u  // node steps per traversal iteration (traverse.h)
#endif
#ifndef KD_TRI_STEPS
#define KD_TRI_STEPS 1u  // triangles per traversal iteration (traverse.h)
#endif
#ifndef KD_OVERLAP
#define KD_OVERLAP 1u  // overlapped node steps and triangle tests (traverse.h)
#endif
#ifndef MCPT_TRACE_SITES
#define MCPT_TRACE_SITES 2u  // rays traced from one call or two (integrator.h: step_path())
#endif
#if MCPT_TRACE_SITES == 1u
#define MCPT_CARRIED_SHADOW 1  // the path carries a shadow ray between steps
#endif
#if (MCPT_FEATURES & FEATURE_LIGHT_TREE) != 0u
#define MCPT_CARRIED_RECEIVER 1  // the path carries the receiver's normal (light tree)
#endif
// The path carries the absorbing glass it is inside. (NVIDIA's OpenCL keeps a larger path in
// local memory: one more word in every build ran the Cornell box 28% slower there.)
#if (MCPT_FEATURES & FEATURE_VOLUME) != 0u
#define MCPT_CARRIED_MEDIUM 1
#endif
#endif

// Whether this build keeps the code of feature f (a compile-time or specialization constant,
// so the compiler drops the branches of features left out).
#define HAS_FEATURE(f) ((MCPT_FEATURES & (f)) != 0u)

#endif  // MCPT_GPU_SCENE_ACCESS_H
