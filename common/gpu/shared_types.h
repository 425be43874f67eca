// The one definition of every GPU struct, constant and binding slot, read by C++, OpenCL C
// and GLSL. Structs hold only 32-bit scalars so that C++, OpenCL C and GLSL std430/std140
// agree on every offset without padding rules; C++ checks each size with static_assert.
#ifndef MCPT_GPU_SHARED_TYPES_H
#define MCPT_GPU_SHARED_TYPES_H

#include "platform.h"

MCPT_NAMESPACE_BEGIN

// Material kinds (GpuMaterial.type).
#define MAT_DIFFUSE 0u
#define MAT_MIRROR 1u
#define MAT_GLASS 2u
#define MAT_PBR 3u  // glTF metallic-roughness: GGX specular (Schlick Fresnel) over a diffuse base
#define MAT_ROUGH_GLASS 4u  // rough dielectric: GGX reflection and refraction (Walter 2007)
// GpuMaterial.type: the kind in the low byte; flags above it.
#define MAT_KIND_MASK 0xffu
#define MAT_TWO_SIDED 0x100u  // triangles emit from both faces (glTF doubleSided)
// Glass whose inside absorbs (glTF KHR_materials_volume, Beer-Lambert): the absorption
// coefficient per unit length in place of the fields glass does not read, `metallic` its
// largest channel and `specular`'s bits the three channels over it in 10-bit steps
// (material_sigma in bsdf.h; pack_material on the host).
#define MAT_VOLUME 0x200u
// An emissive triangle that is half of a rectangle, the other half emissive too: next-event
// estimation samples the whole rectangle by solid angle (rect_light.h).
#define MAT_RECT_LIGHT 0x400u

// Light kinds (GpuLight.prim high bits): a triangle index, a sphere index | LIGHT_SPHERE_BIT,
// a punctual light index | LIGHT_PUNCTUAL_BIT, or LIGHT_ENVIRONMENT (the one environment).
#define LIGHT_SPHERE_BIT 0x80000000u
#define LIGHT_PUNCTUAL_BIT 0x40000000u
#define LIGHT_ENVIRONMENT 0x20000000u
#define LIGHT_INDEX_MASK 0x1fffffffu

// Punctual light kinds (GpuPunctualLight.type): glTF KHR_lights_punctual.
#define PUNCTUAL_POINT 0u
#define PUNCTUAL_SPOT 1u
#define PUNCTUAL_DIRECTIONAL 2u

// Scene features (bits of MCPT_FEATURES): code a scene does not need is compiled out,
// through -D in OpenCL and a specialization constant in Vulkan (common/scene_features.h).
#define FEATURE_TRIANGLES 1u        // triangle meshes
#define FEATURE_SPHERES 2u          // analytic spheres
#define FEATURE_DIFFUSE 4u          // Lambertian surfaces (and next-event estimation)
#define FEATURE_MIRROR 8u           // perfect mirrors
#define FEATURE_GLASS 16u           // dielectrics (Fresnel, refraction, total internal reflection)
#define FEATURE_TRIANGLE_LIGHTS 32u  // emissive triangles (each on its own: rectangles below)
#define FEATURE_SPHERE_LIGHTS 64u   // emissive spheres
#define FEATURE_KDTREE 128u         // k-d traversal with its stack (else: test every triangle)
#define FEATURE_MICROFACET 256u     // GGX materials: metallic-roughness, rough glass (microfacet.h)
#define FEATURE_SHADING_NORMALS 512u  // per-vertex normals (smooth shading) and normal maps
#define FEATURE_TEXTURES 1024u      // texture coordinates and texture fetches (texture.h)
#define FEATURE_ALPHA_MASK 2048u    // alphaMode MASK: cut-out surfaces rays pass through
#define FEATURE_PUNCTUAL_LIGHTS 4096u  // point, spot and directional lights (KHR_lights_punctual)
#define FEATURE_ENVIRONMENT 8192u   // an environment map or constant background (lights.h)
#define FEATURE_LIGHT_TREE 65536u   // next-event estimation picks local lights by a tree
#define FEATURE_BVH 131072u         // 8-wide BVH traversal (traverse_bvh.h)
#define FEATURE_LIGHT_CONTRIBUTION 262144u  // a few lamps, picked by contribution (integrator.h)
#define FEATURE_VOLUME 524288u      // absorbing glass (MAT_VOLUME): Beer-Lambert inside
#define FEATURE_CLEARCOAT 1048576u  // a clear GGX coat over metallic-roughness (layers.h)
#define FEATURE_SHEEN 2097152u      // a sheen layer over metallic-roughness (layers.h)
#define FEATURE_RECT_LIGHTS 4194304u     // emissive rectangles of two triangles (rect_light.h)
#define FEATURE_ALL (16383u | 8323072u)  // bits 0-13 and 16-22: all but the two below
#define FEATURE_TEST_NAN 16384u     // tests only: poison samples of pixels 0 and 1 (never in ALL)
#define FEATURE_INDEPENDENT_SAMPLER 32768u  // independent uniforms, not Sobol (A/B, never in ALL)
#define FEATURE_BITS 8388607u               // every bit above
#define FEATURE_COUNT 23

// The smallest GGX alpha a MAT_PBR material keeps (roughness 0.01): below it the lobe's peak
// exceeds float range in NEE; roughness 0 metals are MAT_MIRROR.
#define MIN_GGX_ALPHA 1.0e-4f
// The smallest sheen roughness kept (glTF's default is 0): below it the sheen's peak at grazing
// angles exceeds what the albedo table (sheen_albedo_table.h) resolves.
#define MIN_SHEEN_ROUGHNESS 0.07f

// k-d node layout (pbrt): axis in the low 2 bits of `flags`, 3 = leaf; below child implicit.
#define KD_LEAF 3u

// Binding slots, shared by the OpenCL kernel argument order and the Vulkan descriptor set.
// Scene arrays share buffers so the shader binds 4 storage buffers, the minimum every Vulkan
// device supports per stage: the tree buffer holds the k-d nodes, then the leaf index array
// (from word 2 * num_nodes); the shading buffer holds the spheres (32 bytes each), then the
// materials (96 bytes each, from the first 96-byte boundary after the spheres, so that GLSL
// indexes them as an array), then the lights (16 bytes each), at the words below.
#define BINDING_PARAMS 0
#define BINDING_TREE 1
#define BINDING_TRIANGLES 2
#define BINDING_SHADING 3
#define BINDING_ACCUM 4
#define BINDING_COUNT 5
// Vulkan only: the tree, triangle and shading buffers once more, as texel buffers (two 32-bit
// words per texel for the tree, four for the others), which the SPIR-V module built with
// MCPT_SCENE_TEXELS reads instead of the storage buffers: llvmpipe fetches a texel for 8 lanes
// with one vector gather, where it reads a storage buffer lane by lane, each word behind its
// own branches.
#define BINDING_TREE_TEXELS 5
#define BINDING_TRIANGLE_TEXELS 6
#define BINDING_SHADING_TEXELS 7
#define VK_BINDING_COUNT 8
// Vulkan with ray queries or the ray-tracing pipeline only (MCPT_RAY_QUERY, MCPT_RAY_PIPELINE):
// the scene's top-level acceleration structure, one more descriptor after the eight above.
#define BINDING_TLAS 8
#define VK_RAY_QUERY_BINDING_COUNT 9
#define MATERIAL_WORDS 24u
#define SHADING_MATERIALS_WORD(num_spheres) \
    (MATERIAL_WORDS * ((8u * (num_spheres) + MATERIAL_WORDS - 1u) / MATERIAL_WORDS))
#define SHADING_LIGHTS_WORD(num_spheres, num_materials) \
    (SHADING_MATERIALS_WORD(num_spheres) + MATERIAL_WORDS * (num_materials))
// After the lights: the texture table (GpuTexture), then the texels (GpuParams.texels_word,
// even), two words per texel. The triangle buffer holds the triangles, then (scenes with
// FEATURE_SHADING_NORMALS or FEATURE_TEXTURES) one GpuTriangleAttributes per triangle.
#define NO_TEXTURE 0xffffffffu
#define NO_TEXTURE16 0xffffu
#define TEXTURE_WRAP_REPEAT 0u
#define TEXTURE_WRAP_CLAMP 1u
#define TEXTURE_WRAP_MIRROR 2u
#define TEXTURE_NEAREST 16u  // GpuTexture.flags: wrap_s | wrap_t << 2 | TEXTURE_NEAREST
#define STORAGE_BUFFER_COUNT 4  // every binding but the parameters (a uniform buffer)
#define TEXEL_BUFFER_COUNT 3    // Vulkan's texel-buffer views

// Default compute workgroup size along x (a device may lower it).
#define WORKGROUP_SIZE 64

// Interior: split = split position, flags = (above_child << 2) | axis.
// Leaf: split = first index into the leaf-index array (as uint bits), flags = (count << 2) | 3.
MCPT_STRUCT(KdNode) {
    uint split_or_offset;
    uint flags;
};

// A node of the 8-wide BVH (after Ylitie, Karras & Laine, HPG 2017), fourteen 16-byte quads;
// the tree buffer holds them in place of k-d nodes (GpuParams.num_nodes counts 8-byte units,
// 28 a node), then the leaf index array. Child boxes lie on a grid of 2^e from origin p,
// conservatively, with a cell of margin on every side; each plane is stored as its offset
// from p in floats (q * 2^e for a grid index q of 0-255, exact), so the traversal converts
// nothing (on NVIDIA 5-19% faster than bytes converted per child, docs/traversal.md).
//   q0: p.x, p.y, p.z (floats); e_x | e_y << 8 | e_z << 16 (biased by 127) | imask << 24
//   q1: first internal child's node index, first leaf index of the leaf children, meta 0-3,
//       meta 4-7 (one byte per slot, slot k in byte k % 4 of word 2 + k / 4)
//   q2 + 6h + 2a + hi: the plane (hi = 0: low, 1: high) on axis a of slots 4h to 4h + 3
// imask bit s: slot s holds an internal node; those are stored contiguously from the first
// child's index, in slot order. meta: 0 for an empty slot; an internal child (1 << 5) | (24 +
// s); a leaf child of 1-3 triangles (0b1, 0b11, 0b111 << 5) | its first triangle's offset
// from the node's first leaf index (0-21). Slot s holds the child nearest along the octant
// of directions whose negative axes are its bits (x = 4, y = 2, z = 1); a node of at most
// four leaves and no internal child uses slots 0-3 (meta 4-7 is 0: one half tested).
MCPT_STRUCT(BvhNode) {
    uint words[56];
};
#define BVH_NODE_UNITS 28u  // 8-byte units of the tree buffer per BvhNode
#define BVH_PLANES_QUAD 2u  // quad of a node's first planes
#define BVH_HALF_QUADS 6u   // quads of planes per half (four slots)
#define BVH_WIDTH 8u
#define BVH_LEAF_MAX 3u     // triangles per leaf child

// A triangle in world space with its material; 40 bytes, scalar-aligned.
MCPT_STRUCT(GpuTriangle) {
    float v0x, v0y, v0z;
    float v1x, v1y, v1z;
    float v2x, v2y, v2z;
    uint material;
};

// Per-vertex data of a triangle: normals in octahedral snorm16x2 form (normal_from_oct in
// texture.h), texture coordinates 0 (glTF's: v down the image).
MCPT_STRUCT(GpuTriangleAttributes) {
    uint n0, n1, n2;
    uint pad;
    float u0, v0, u1, v1, u2, v2;
};

// A texture: width x height texels of linear RGBA as half floats (two words: rg, ba), row 0 at
// v = 0, from word `offset` of the texel array.
MCPT_STRUCT(GpuTexture) {
    uint width, height;
    uint offset;
    uint flags;
};

MCPT_STRUCT(GpuSphere) {
    float cx, cy, cz, radius;
    uint material;
    uint pad0, pad1, pad2;
};

MCPT_STRUCT(GpuMaterial) {
    float r, g, b;  // diffuse albedo, mirror tint, glass tint or metallic-roughness base color
    uint type;      // MAT_* kind | MAT_TWO_SIDED, MAT_VOLUME, MAT_RECT_LIGHT
    float er, eg, eb;  // emitted radiance (front side of triangles, or both; outside of spheres)
    float ior;         // index of refraction (glass; the dielectric Fresnel of MAT_PBR)
    float metallic;    // MAT_PBR: 0 dielectric over diffuse, 1 conductor
    float alpha;       // MAT_PBR, MAT_ROUGH_GLASS: GGX alpha = roughness^2 (>= MIN_GGX_ALPHA)
    float specular;    // MAT_PBR: KHR_materials_specular factor (scales the dielectric Fresnel)
    float alpha_cutoff;  // alphaMode MASK: cut out where alpha < cutoff (0: opaque)
    // Textures (GpuTexture index or NO_TEXTURE): base color (rgb, alpha) times r, g, b; glTF's
    // metallic-roughness (b: metallic, g: roughness) times the factors; tangent-space normals;
    // emission times er, eg, eb.
    uint tex_base, tex_metal_rough, tex_normal, tex_emission;
    // Layers over MAT_PBR (layers.h): KHR_materials_clearcoat's weight (0: none) and the coat's
    // GGX alpha; KHR_materials_sheen's color (0: none) and roughness. Their textures, two
    // 16-bit indices a word (NO_TEXTURE16: none): clearcoat (r) | clearcoat roughness (g) << 16,
    // sheen color (rgb) | sheen roughness (a) << 16.
    float clearcoat, clearcoat_alpha;
    float sheen_r, sheen_g, sheen_b, sheen_roughness;
    uint tex_clearcoat, tex_sheen;
};

// A punctual light (KHR_lights_punctual) in world space: 64 bytes, in the texel region from
// GpuParams.punctual_word (a multiple of 4 words from the buffer's start). Intensity in W/sr
// (point, spot) or W/m^2 (directional); `dx, dy, dz` the unit direction light travels (spot,
// directional); range 0: unbounded; the spot's smooth falloff is glTF's:
// clamp(cos * spot_scale + spot_offset, 0, 1)^2.
MCPT_STRUCT(GpuPunctualLight) {
    float px, py, pz;
    uint type;  // PUNCTUAL_*
    float dx, dy, dz;
    float range;
    float r, g, b;
    float spot_scale, spot_offset;
    uint pad0, pad1, pad2;
};

// One entry of the light alias table (Walker/Vose): pick i uniformly, keep it with
// probability `prob`, else take `alias`. `pmf` is the total probability of light i.
MCPT_STRUCT(GpuLight) {
    uint prim;  // triangle index, or sphere index | LIGHT_SPHERE_BIT
    uint alias;
    float prob;
    float pmf;
};

// A node of the light tree (light_tree.h): the bounds of its lights, their power, and its
// first child (the second follows it), or LIGHT_TREE_LEAF | the light's slot in the light table.
MCPT_STRUCT(GpuLightTreeNode) {
    float min_x, min_y, min_z, power;
    float max_x, max_y, max_z;
    uint child;
    // The cone of directions its lights emit into (Conty Estevez & Kulla 2018): every light
    // of the node emits only within cos_o of the axis (-1: every way), each over a hemisphere.
    float axis_x, axis_y, axis_z, cos_o;
};
#define LIGHT_TREE_LEAF 0x80000000u

// Per-dispatch parameters (OpenCL __constant buffer, Vulkan uniform buffer).
MCPT_STRUCT(GpuParams) {
    uint width, height;
    uint pixel_offset, pixel_count;  // this dispatch covers pixels [offset, offset+count)
    uint sample_offset, samples_per_dispatch;
    uint accumulate;  // 0: overwrite the accumulation buffer, 1: add to it
    uint seed;
    uint max_depth, rr_depth;
    uint num_triangles, num_spheres, num_lights, num_nodes;
    float light_power_total;  // sum over lights of area * mean(Le): pdf_area(x) = mean(Le(x)) / total
    float scene_min_x, scene_min_y, scene_min_z;
    float scene_max_x, scene_max_y, scene_max_z;
    float cam_px, cam_py, cam_pz;  // pinhole position
    float cam_ux, cam_uy, cam_uz;  // right * tan(fov/2) * aspect
    float cam_vx, cam_vy, cam_vz;  // up * tan(fov/2)
    float cam_wx, cam_wy, cam_wz;  // forward (unit)
    float light_scale;  // 1.0; negative-control tests scale every emitter
    uint num_materials;
    // Paths carried across dispatches: a round gives each pixel of [pixel_offset,
    // pixel_offset + pixel_count) samples_per_dispatch samples; its first dispatch starts them
    // (round_start), each dispatch runs at most bounce_budget bounces per pixel, and the host
    // repeats it until no pixel owes samples. Pixel i keeps its path in slot i - state_base.
    uint round_start, bounce_budget;
    uint state_base, state_slots;  // state_slots: slots after the accumulation sums
    // 0: the buffer holds the sums of every pixel; 1: only those of the tile at state_base
    // (state_slots pixels: images whose sums exceed the device's largest buffer; the host
    // reads the window back after each round).
    uint accum_window;
    uint num_textures;
    uint texels_word;  // first word of the texels in the shading buffer
    uint scene_flags;  // SCENE_* below
    // 1: a round's samples follow the sample plan (adaptive sampling): slot i's pixel takes
    // plan[2i + 1] samples from sample index plan[2i]; 0: every pixel takes
    // samples_per_dispatch samples from sample_offset.
    uint sample_plan;
    // Punctual lights: their number, and their first word after texels_word.
    uint num_punctual, punctual_word;
    // The environment (equirectangular, row 0 at +Y), words after texels_word: env_word, one
    // 16-byte texel each (radiance rgb, then the pdf of its uv square: w); env_rows_word, the
    // CDF of its rows (height + 1 floats, then height guide words: lights.h, cdf_pick);
    // env_cols_word, that of each row's columns (2 width + 1 words a row). env_u_shift: the
    // rotation about +Y as a shift of u. env_pmf: the probability that next-event estimation
    // picks the environment.
    uint env_width, env_height;
    uint env_word, env_rows_word, env_cols_word;
    float env_u_shift, env_pmf;
    // Reproducible renders with their exact sums on the device (exact_vec4 > 0, the vec4 where
    // they start): FOLD_ADD or FOLD_STORE makes a dispatch add (store) each pixel's float sums,
    // one whole group, to (as) its exact sums and trace nothing; overflow sets the pending word.
    uint fold_sums, exact_vec4;
    // The light tree (FEATURE_LIGHT_TREE, light_tree.h), words after texels_word: its nodes
    // (GpuLightTreeNode each, 12 words, root first) and the (prim, trail) pairs of its lights
    // sorted by prim (num_light_trails of them); the probability that next-event estimation takes
    // the tree (else the alias table of lights at infinity); the least squared distance its
    // importance divides by.
    uint light_tree_word, light_trails_word;
    float light_tree_pmf, light_tree_eps2;
    uint num_tree_lights;
    // FEATURE_SHEEN: the sheen's albedo table (sheen_albedo_table.h), words after texels_word,
    // where GLSL reads it (layers.h; a constant array there took lavapipe minutes to compile).
    uint sheen_albedo_word;
    // Tests (ray_cast.h): non-zero, a dispatch casts ray pixel (cast_ray()) of each of its
    // pixels, writes its closest hit (t, prim, b1, b2 as bits) to the pixel's first sum vec4
    // and its any-hit prim and both statuses to the second, and traces nothing else.
    uint ray_cast;
    // The light tree's (prim, trail) pairs: num_tree_lights, and a rectangle's other half
    // (rect_light.h) beside its head.
    uint num_light_trails;
    uint pad_params3;  // std140: a multiple of 16 bytes
};
// GpuParams.scene_flags: the triangle buffer holds GpuTriangleAttributes after the triangles;
// some material has an alpha mask (the traversal reads materials only then).
#define SCENE_VERTEX_DATA 1u
#define SCENE_ALPHA_MASK 2u
#define SCENE_KD_OVERLAP 4u  // the C++ build only (tests): overlapped traversal steps (traverse.h)
#define SCENE_BVH 8u         // the tree buffer holds a BVH (BvhNode), not a k-d tree
// Next-event estimation picks among the scene's lights, all punctual and at most
// LIGHT_CONTRIBUTION_MAX of them, by each one's unshadowed contribution (integrator.h).
#define SCENE_LIGHT_CONTRIBUTION 16u
// Emissive triangles sampled by area, not by solid angle (triangle_light.h; render
// --triangle-light-sampling area, to measure against).
#define SCENE_TRIANGLE_LIGHTS_BY_AREA 32u
// Vulkan only: rays are traced by the driver against the scene's acceleration structures at
// BINDING_TLAS (traverse_driver.h), through ray queries (VK_KHR_ray_query; --tree rayquery) or
// the ray-tracing pipeline (VK_KHR_ray_tracing_pipeline; --tree raypipeline); the tree buffer
// holds no tree.
#define SCENE_RAY_QUERY 64u
#define SCENE_RAY_PIPELINE 512u
// Emissive triangles and rectangles sampled by solid angle with the uniforms warped toward
// the receiver's cosine wherever they are (triangle_light.h: cosine_warp_on; render
// --triangle-light-sampling cosine), or nowhere (uniform); else where they span 0.2 sr or more.
#define SCENE_TRIANGLE_LIGHTS_COSINE 128u
#define SCENE_TRIANGLE_LIGHTS_UNIFORM 256u
#define LIGHT_CONTRIBUTION_MAX 8u

// Accumulation buffer: two vec4 per pixel (every pixel, or the window's state_slots pixels
// from state_base when accum_window is set).
//   [2*i]   = sum of radiance (rgb), number of non-finite samples (w)
//   [2*i+1] = sum of squared radiance (rgb), number of rays traced (w)
// then the path state of state_slots slots (PATH_STATE_VEC4 vec4 each, integrator.h), then
// one vec4 whose first word is set when a pixel still owes samples after a dispatch, then the
// sample plan: PLAN_WORDS_PER_SLOT words per slot (first sample index, samples), written by
// the host before a round when GpuParams.sample_plan is set.
// Reproducible renders may add, after the plan, the exact sums of whole groups (fold_sums.h):
// EXACT_VEC4_PER_PIXEL uvec4 per pixel of the image, at GpuParams.exact_vec4.
//   [7*i .. 7*i+2] = sums of radiance (rgb), [7*i+3 .. 7*i+5] = sums of squares (rgb): each a
//                    128-bit two's complement fixed-point number (exact_sums.h), low word first
//   [7*i+6]        = non-finite samples, rays traced: two 64-bit counts, low word first
#define ACCUM_VEC4_PER_PIXEL 2u
#define EXACT_VEC4_PER_PIXEL 7u
#define FOLD_ADD 1u
#define FOLD_STORE 2u
#define PATH_STATE_VEC4 6u
#define PLAN_WORDS_PER_SLOT 2u
#define MAX_STATE_SLOTS 1048576u  // 96 MiB of path state at most

MCPT_NAMESPACE_END

#if defined(MCPT_CPP)
static_assert(FEATURE_ALL == ((FEATURE_ENVIRONMENT * 2u - 1u) | FEATURE_LIGHT_TREE | FEATURE_BVH |
                              FEATURE_LIGHT_CONTRIBUTION | FEATURE_VOLUME | FEATURE_CLEARCOAT |
                              FEATURE_SHEEN | FEATURE_RECT_LIGHTS),
              "FEATURE_ALL: every feature but the two for tests and A/B runs");
static_assert(sizeof(mcpt::gpu::KdNode) == 8, "KdNode must be 8 bytes");
static_assert(sizeof(mcpt::gpu::BvhNode) == BVH_NODE_UNITS * 8, "BvhNode must be 224 bytes");
static_assert(BVH_PLANES_QUAD + 2 * BVH_HALF_QUADS == BVH_NODE_UNITS / 2, "quads of a BvhNode");
static_assert(sizeof(mcpt::gpu::GpuTriangle) == 40, "GpuTriangle must be 40 bytes");
static_assert(sizeof(mcpt::gpu::GpuTriangle) % 8 == 0, "GLSL reads triangles as uvec2 words");
static_assert(sizeof(mcpt::gpu::GpuSphere) == 32, "GpuSphere must be 32 bytes");
static_assert(sizeof(mcpt::gpu::GpuMaterial) == MATERIAL_WORDS * 4, "GpuMaterial: 96 bytes");
static_assert(sizeof(mcpt::gpu::GpuLight) == 16, "GpuLight must be 16 bytes");
static_assert(sizeof(mcpt::gpu::GpuParams) == 64 * 4, "GpuParams must be 64 words");
static_assert(sizeof(mcpt::gpu::GpuLightTreeNode) == 48, "GpuLightTreeNode must be 48 bytes");
static_assert(sizeof(mcpt::gpu::GpuPunctualLight) == 64, "GpuPunctualLight must be 64 bytes");
static_assert(sizeof(mcpt::gpu::GpuTriangleAttributes) == 40, "GpuTriangleAttributes: 40 bytes");
static_assert(sizeof(mcpt::gpu::GpuTexture) == 16, "GpuTexture must be 16 bytes");
static_assert(offsetof(mcpt::gpu::GpuParams, light_power_total) == 14 * 4, "GpuParams layout");
static_assert(offsetof(mcpt::gpu::GpuParams, cam_px) == 21 * 4, "GpuParams layout");
static_assert(offsetof(mcpt::gpu::GpuParams, light_scale) == 33 * 4, "GpuParams layout");
static_assert(offsetof(mcpt::gpu::GpuParams, fold_sums) == 53 * 4, "GpuParams layout");
#endif

#endif  // MCPT_GPU_SHARED_TYPES_H
