// Vulkan entry point of the path tracer: one invocation per pixel of this dispatch's range,
// which continues the pixel's path for at most bounce_budget bounces (step_slot), adds the
// samples that ended to the pixel's sums in the accumulation buffer and keeps the path for the next dispatch.
// Everything else is the shared device code in common/gpu/ (the OpenCL twin is
// kernels/pathtrace.cl, with the same function names). Built with MCPT_RAY_PIPELINE, the same
// entry point is a ray-tracing pipeline's ray-generation shader (one launch per pixel of the
// range, the hit groups in trace_hits.glsl).
#version 460
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_control_flow_attributes : require
#if defined(MCPT_RAY_QUERY)
#extension GL_EXT_ray_query : require  // the driver traces (traverse_driver.h)
#elif defined(MCPT_RAY_PIPELINE)
#extension GL_EXT_ray_tracing : require  // the driver traces (traverse_driver.h)
#endif
#define MCPT_GLSL 1
#include "../common/gpu/fold_sums.h"
#include "../common/gpu/integrator.h"
#include "../common/gpu/ray_cast.h"

#if defined(MCPT_RAY_PIPELINE)
#define INVOCATION_INDEX gl_LaunchIDEXT.x
#else
layout(local_size_x_id = 1) in;
#define INVOCATION_INDEX gl_GlobalInvocationID.x
#endif
layout(std430, binding = BINDING_ACCUM) buffer AccumBlock { vec4 accum[]; };
layout(std430, binding = BINDING_ACCUM) buffer ActiveBlock { uint accum_words[]; };
layout(std430, binding = BINDING_ACCUM) buffer ExactBlock { uvec4 accum_exact[]; };

void main() {
    uint gid = INVOCATION_INDEX;
    if (gid >= params.pixel_count) return;
    uint pixel = params.pixel_offset + gid;
    // The pixel's sums, path state and the pending word.
    AccumPlace at = accum_place(pixel);
    uint sum = at.sum;
    uint state = at.state;
    uint pending = 4u * at.pending;
    // Reproducible: the group's float sums into the exact sums (fold_sums.h), nothing traced.
    if (params.fold_sums != 0u) {
        uint exact = params.exact_vec4 + EXACT_VEC4_PER_PIXEL * pixel;
        ExactPixel px;
        for (uint k = 0u; k < EXACT_VEC4_PER_PIXEL; ++k) px.w[k] = accum_exact[exact + k];
        FoldStep f = fold_pixel(accum[sum], accum[sum + 1u], px, params.fold_sums);
        for (uint k = 0u; k < EXACT_VEC4_PER_PIXEL; ++k) accum_exact[exact + k] = f.px.w[k];
        if (!f.ok) accum_words[pending] = 1u;  // out of range
        return;
    }
    // Tests: one ray cast (ray_cast.h), its closest and any hit written, nothing else traced.
    if (params.ray_cast != 0u) {
        Ray ray = cast_ray(pixel);
        Hit h = trace_ray(ray, false), a = trace_ray(ray, true);
        accum[sum] = vec4(h.t, uint_as_float(h.prim), h.b1, h.b2);
        accum[sum + 1u] = vec4(uint_as_float(a.prim), uint_as_float(h.status | (a.status << 8u)),
                               a.t, 0.0f);
        return;
    }
    // Start the pixel's samples of this round, or continue its path.
    PathState st;
    if (params.round_start != 0u) {
        // Every pixel alike, or as the sample plan says (adaptive sampling).
        uint first = params.sample_offset, count = params.samples_per_dispatch;
        if (params.sample_plan != 0u) {
            first = accum_words[at.plan];
            count = accum_words[at.plan + 1u];
        }
        st = start_path(pixel, first);
        st.samples_left = count;
        if (params.accumulate == 0u) {
            accum[sum] = vec4(0.0f);
            accum[sum + 1u] = vec4(0.0f);
        }
    } else {
        PackedState p = PackedState(accum[state], accum[state + 1u], accum[state + 2u],
                                    accum[state + 3u], accum[state + 4u], accum[state + 5u]);
        st = unpack_state(p);
        if (st.samples_left == 0u) return;
    }
    PixelSums sums = PixelSums(accum[sum], accum[sum + 1u]);
    SlotStep r = step_slot(st, pixel, sums);
    accum[sum] = r.sums.sum;
    accum[sum + 1u] = r.sums.sum_sq;
    // A pixel that still owes samples keeps its path, and the host dispatches again (the
    // pending word is a flag, not a count).
    if (r.st.samples_left > 0u) {
        PackedState p = pack_state(r.st);
        accum[state] = p.a;
        accum[state + 1u] = p.b;
        accum[state + 2u] = p.c;
        accum[state + 3u] = p.d;
        accum[state + 4u] = p.e;
        accum[state + 5u] = p.f;
        accum_words[pending] = 1u;
    } else {
        accum[state + 5u] = vec4(0.0f);  // samples_left = 0: later dispatches skip the pixel
    }
}
