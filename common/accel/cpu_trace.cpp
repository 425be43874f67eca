#include "common/accel/cpu_trace.h"

#include "common/gpu/integrator.h"

#include "common/error.h"

namespace mcpt {

namespace {
void check_stack(const GpuScene& s) {
    if (s.stack_size > KD_STACK_SIZE) {
        throw Error("tree too deep for the CPU traversal: stack of " +
                    std::to_string(s.stack_size) + " entries > " + std::to_string(KD_STACK_SIZE));
    }
}
}  // namespace

gpu::Hit cpu_trace(const GpuScene& s, const gpu::Ray& ray, bool any_hit) {
    check_stack(s);
    return gpu::trace_ray(&s.params, s.nodes.data(), s.leaf_indices.data(), s.triangles.data(),
                          s.spheres.data(), s.materials.data(), s.lights.data(), ray, any_hit);
}

gpu::Ray cpu_camera_ray(const GpuScene& s, const gpu::GpuParams& params, float fx, float fy) {
    return gpu::camera_ray(&params, s.nodes.data(), s.leaf_indices.data(), s.triangles.data(),
                           s.spheres.data(), s.materials.data(), s.lights.data(), fx, fy);
}

gpu::PathResult cpu_trace_path(const GpuScene& s, const gpu::GpuParams& params, uint32_t pixel,
                               uint32_t sample_index) {
    check_stack(s);
    return gpu::trace_path(&params, s.nodes.data(), s.leaf_indices.data(), s.triangles.data(),
                           s.spheres.data(), s.materials.data(), s.lights.data(), pixel,
                           sample_index);
}

gpu::RayWork cpu_path_work(const GpuScene& s, const gpu::GpuParams& params, uint32_t pixel,
                           uint32_t sample_index) {
    gpu::RayWork work;
    gpu::path_work = &work;
    cpu_trace_path(s, params, pixel, sample_index);
    gpu::path_work = nullptr;
    return work;
}

}  // namespace mcpt
