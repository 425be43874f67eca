// The device traversal and path tracer compiled for the CPU: the same functions the kernels
// run, used by tests (against brute force), `mcpt tree` and `mcpt bench` (work per ray).
// Only the plain data of gpu/ray_types.h is visible here, not the device dialect's macros.
#pragma once
#include "common/gpu/ray_types.h"
#include "common/render/gpu_scene.h"

namespace mcpt {

// Closest (or any) hit of the ray in the packed scene, through the shared trace_ray().
gpu::Hit cpu_trace(const GpuScene& scene, const gpu::Ray& ray, bool any_hit);

// The camera ray through (fx, fy) in [-1, 1]^2 of params' camera, through the shared
// camera_ray().
gpu::Ray cpu_camera_ray(const GpuScene& scene, const gpu::GpuParams& params, float fx, float fy);

// One path sample through the shared trace_path(); params carries camera and depth settings.
gpu::PathResult cpu_trace_path(const GpuScene& scene, const gpu::GpuParams& params, uint32_t pixel,
                               uint32_t sample_index);

// The traversal work of every ray (camera, bounce, shadow) of that same path sample.
gpu::RayWork cpu_path_work(const GpuScene& scene, const gpu::GpuParams& params, uint32_t pixel,
                           uint32_t sample_index);

}  // namespace mcpt
