// Vulkan entry point of the path tracer: one invocation per pixel of this dispatch's range,
// which continues the pixel's path for at most bounce_budget bounces (step_slot), adds the
// samples that ended to the accumulation buffer and keeps the path for the next dispatch.
// Everything else is the shared device code in common/gpu/ (the OpenCL twin is
// kernels/pathtrace.cl, with the same function names).
#version 450
#extension GL_GOOGLE_include_directive : require
#define MCPT_GLSL 1
#include "../common/gpu/integrator.h"

layout(local_size_x_id = 1) in;
layout(std430, binding = BINDING_ACCUM) buffer AccumBlock { vec4 accum[]; };
layout(std430, binding = BINDING_ACCUM) buffer ActiveBlock { uint accum_words[]; };

void main() {
    uint gid = gl_GlobalInvocationID.x;
    if (gid >= params.pixel_count) return;
    uint pixel = params.pixel_offset + gid;
    // The pixel's sums (in the window when the buffer holds only the tile's), path state and
    // the pending word (layout in shared_types.h).
    bool window = params.accum_window != 0u;
    uint sum_pixels = window ? params.state_slots : params.width * params.height;
    uint sum = ACCUM_VEC4_PER_PIXEL * (pixel - (window ? params.state_base : 0u));
    uint state = ACCUM_VEC4_PER_PIXEL * sum_pixels + PATH_STATE_VEC4 * (pixel - params.state_base);
    uint pending = 4u * (ACCUM_VEC4_PER_PIXEL * sum_pixels + PATH_STATE_VEC4 * params.state_slots);
    // Start the pixel's samples of this round, or continue its path.
    PathState st;
    if (params.round_start != 0u) {
        st = start_path(pixel, params.sample_offset);
        st.samples_left = params.samples_per_dispatch;
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
    SlotStep r = step_slot(st, pixel);
    accum[sum] += r.add.sum;
    accum[sum + 1u] += r.add.sum_sq;
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
