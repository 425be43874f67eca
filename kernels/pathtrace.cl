// OpenCL entry point of the path tracer: one work-item per pixel of this dispatch's range,
// which continues the pixel's path for at most bounce_budget bounces (step_slot), adds the
// samples that ended to the pixel's sums in the accumulation buffer and keeps the path for the next dispatch.
// Everything else is the shared device code in common/gpu/ (the GLSL twin is
// shaders/pathtrace.comp, with the same function names).
#include "../common/gpu/fold_sums.h"
#include "../common/gpu/integrator.h"
#include "../common/gpu/ray_cast.h"

__kernel void pathtrace(__global const GpuParams* params, __global const uint* tree,
                        __global const GpuTriangle* triangles, __global const uint* shading,
                        __global float4* accum) {
    // The arrays inside the shared buffers (layout in shared_types.h).
    __global const KdNode* nodes = (__global const KdNode*)tree;
    __global const uint* leaf_indices = tree + 2u * params->num_nodes;
    __global const GpuSphere* spheres = (__global const GpuSphere*)shading;
    __global const GpuMaterial* materials =
        (__global const GpuMaterial*)(shading + SHADING_MATERIALS_WORD(params->num_spheres));
    __global const GpuLight* lights = (__global const GpuLight*)(
        shading + SHADING_LIGHTS_WORD(params->num_spheres, params->num_materials));
    __global const GpuTriangleAttributes* attributes =
        (__global const GpuTriangleAttributes*)(triangles + params->num_triangles);
    __global const GpuTexture* textures = (__global const GpuTexture*)(lights + params->num_lights);
    __global const uint* texels = shading + params->texels_word;
    uint gid = get_global_id(0);
    if (gid >= params->pixel_count) return;
    uint pixel = params->pixel_offset + gid;
    // The pixel's sums, path state and the pending word.
    AccumPlace at = accum_place(SCENE_ARGS_ pixel);
    uint sum = at.sum;
    // Reproducible: the group's float sums into the exact sums (fold_sums.h), nothing traced.
    if (params->fold_sums != 0u) {
        __global uint4* exact =
            (__global uint4*)accum + params->exact_vec4 + EXACT_VEC4_PER_PIXEL * pixel;
        ExactPixel px;
        for (uint k = 0u; k < EXACT_VEC4_PER_PIXEL; ++k) px.w[k] = exact[k];
        FoldStep f = fold_pixel(accum[sum], accum[sum + 1u], px, params->fold_sums);
        for (uint k = 0u; k < EXACT_VEC4_PER_PIXEL; ++k) exact[k] = f.px.w[k];
        if (!f.ok) *(__global uint*)(accum + at.pending) = 1u;  // out of range
        return;
    }
    // Tests: one ray cast (ray_cast.h), its closest and any hit written, nothing else traced.
    if (params->ray_cast != 0u) {
        Ray ray = cast_ray(SCENE_ARGS_ pixel);
        Hit h = trace_ray(SCENE_ARGS_ ray, false), a = trace_ray(SCENE_ARGS_ ray, true);
        accum[sum] = (float4)(h.t, as_float(h.prim), h.b1, h.b2);
        accum[sum + 1u] = (float4)(as_float(a.prim), as_float(h.status | (a.status << 8u)), a.t, 0.0f);
        return;
    }
    __global float4* state = accum + at.state;
    __global uint* pending = (__global uint*)(accum + at.pending);
    // Start the pixel's samples of this round, or continue its path.
    PathState st;
    if (params->round_start != 0u) {
        // Every pixel alike, or as the sample plan says (adaptive sampling).
        uint first = params->sample_offset, count = params->samples_per_dispatch;
        if (params->sample_plan != 0u) {
            __global const uint* plan = (__global const uint*)accum + at.plan;
            first = plan[0];
            count = plan[1];
        }
        st = start_path(SCENE_ARGS_ pixel, first);
        st.samples_left = count;
        if (params->accumulate == 0u) {
            accum[sum] = (float4)(0.0f);
            accum[sum + 1u] = (float4)(0.0f);
        }
    } else {
        PackedState p = {state[0], state[1], state[2], state[3], state[4], state[5]};
        st = unpack_state(p);
        if (st.samples_left == 0u) return;
    }
    PixelSums sums = {accum[sum], accum[sum + 1u]};
    SlotStep r = step_slot(SCENE_ARGS_ st, pixel, sums);
    accum[sum] = r.sums.sum;
    accum[sum + 1u] = r.sums.sum_sq;
    // A pixel that still owes samples keeps its path, and the host dispatches again (the
    // pending word is a flag, not a count).
    if (r.st.samples_left > 0u) {
        PackedState p = pack_state(r.st);
        state[0] = p.a, state[1] = p.b, state[2] = p.c;
        state[3] = p.d, state[4] = p.e, state[5] = p.f;
        *pending = 1u;
    } else {
        state[5] = (float4)(0.0f);  // samples_left = 0: later dispatches skip the pixel
    }
}
