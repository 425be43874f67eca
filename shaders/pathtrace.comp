// Vulkan entry point of the path tracer: one invocation per pixel of this dispatch's range,
// samples_per_dispatch paths each, sums written to (or added to) the accumulation buffer.
// Everything else is the shared device code in common/gpu/ (the OpenCL twin is
// kernels/pathtrace.cl, with the same function names).
#version 450
#extension GL_GOOGLE_include_directive : require
#define MCPT_GLSL 1
#include "../common/gpu/integrator.h"

layout(local_size_x_id = 1) in;
layout(std430, binding = BINDING_ACCUM) buffer AccumBlock { vec4 accum[]; };

void main() {
    uint gid = gl_GlobalInvocationID.x;
    if (gid >= params.pixel_count) return;
    uint pixel = params.pixel_offset + gid;
    PixelSums acc = render_pixel(SCENE_ARGS_ pixel);
    if (params.accumulate != 0u) {
        acc.sum += accum[2u * pixel];
        acc.sum_sq += accum[2u * pixel + 1u];
    }
    accum[2u * pixel] = acc.sum;
    accum[2u * pixel + 1u] = acc.sum_sq;
}
