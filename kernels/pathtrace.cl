// OpenCL entry point of the path tracer: one work-item per pixel of this dispatch's range,
// samples_per_dispatch paths each, sums written to (or added to) the accumulation buffer.
// Everything else is the shared device code in common/gpu/ (the GLSL twin is
// shaders/pathtrace.comp, with the same function names).
#include "../common/gpu/integrator.h"

__kernel void pathtrace(__global const GpuParams* params, __global const uint* tree,
                        __global const GpuTriangle* triangles, __global const uint* shading,
                        __global float4* accum) {
    // The arrays inside the shared buffers (layout in shared_types.h).
    __global const KdNode* nodes = (__global const KdNode*)tree;
    __global const uint* leaf_indices = tree + 2u * params->num_nodes;
    __global const GpuSphere* spheres = (__global const GpuSphere*)shading;
    __global const GpuMaterial* materials =
        (__global const GpuMaterial*)(shading + 8u * params->num_spheres);
    __global const GpuLight* lights =
        (__global const GpuLight*)(shading + 8u * (params->num_spheres + params->num_materials));
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
