// OpenCL entry point of the path tracer: one work-item per pixel of this dispatch's range,
// samples_per_dispatch paths each, sums written to (or added to) the accumulation buffer.
// Everything else is the shared device code in common/gpu/ (the GLSL twin is
// shaders/pathtrace.comp, with the same function names).
#include "../common/gpu/integrator.h"

__kernel void pathtrace(__global const GpuParams* params, __global const KdNode* nodes,
                        __global const uint* leaf_indices, __global const GpuTriangle* triangles,
                        __global const GpuSphere* spheres, __global const GpuMaterial* materials,
                        __global const GpuLight* lights, __global float4* accum) {
    uint gid = get_global_id(0);
    if (gid >= params->pixel_count) return;
    uint pixel = params->pixel_offset + gid;
    PixelSums acc = render_pixel(SCENE_ARGS_ pixel);
    if (params->accumulate != 0u) {
        acc.sum += accum[2u * pixel];
        acc.sum_sq += accum[2u * pixel + 1u];
    }
    accum[2u * pixel] = acc.sum;
    accum[2u * pixel + 1u] = acc.sum_sq;
}
