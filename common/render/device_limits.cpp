#include "common/render/device_limits.h"

#include <sstream>

#include "common/error.h"

namespace mcpt {

std::vector<std::pair<std::string, uint64_t>> device_buffers(const GpuScene& scene, int width,
                                                             int height,
                                                             uint64_t max_buffer_bytes) {
    const uint64_t accum = accum_layout(uint64_t(width) * uint64_t(height), max_buffer_bytes).bytes;
    const uint64_t tree = scene.nodes.size() * sizeof(gpu::KdNode) + scene.leaf_indices.size() * 4;
    const uint64_t shading = scene.spheres.size() * sizeof(gpu::GpuSphere) +
                             scene.materials.size() * sizeof(gpu::GpuMaterial) +
                             scene.lights.size() * sizeof(gpu::GpuLight) +
                             (scene.spheres.size() % 2) * sizeof(gpu::GpuSphere) +
                             scene.textures.size() * sizeof(gpu::GpuTexture) +
                             scene.texels.size() * 4;
    const uint64_t triangles = scene.triangles.size() * sizeof(gpu::GpuTriangle) +
                               scene.attributes.size() * sizeof(gpu::GpuTriangleAttributes);
    return {{"k-d tree (nodes and leaf indices)", tree},
            {"triangles", triangles},  // with their per-vertex data
            {"shading data (spheres, materials, lights, textures)", shading},
            {"accumulation buffer", accum},
            {"parameters", sizeof(gpu::GpuParams)}};
}

void check_device_limits(const GpuScene& scene, int width, int height, const DeviceInfo& device,
                         const std::string& where) {
    const MemoryLimits& m = device.memory;
    uint64_t total = 0;
    for (const auto& [what, bytes] : device_buffers(scene, width, height, m.max_buffer_bytes)) {
        total += bytes;
        // "the accumulation buffer needs", "triangles need".
        const std::string need = what + (what == "triangles" ? " need " : " needs ");
        if (m.max_buffer_bytes > 0 && bytes > m.max_buffer_bytes) {
            throw Error("scene too large for " + where + ": " + need + human_bytes(bytes) + ", " +
                        m.max_buffer_name + " is " + human_bytes(m.max_buffer_bytes) +
                        m.max_buffer_note);
        }
        if (m.max_allocation_bytes > 0 && bytes > m.max_allocation_bytes) {
            throw Error("scene too large for " + where + ": " + need + human_bytes(bytes) + ", " +
                        m.max_allocation_name + " is " + human_bytes(m.max_allocation_bytes));
        }
    }
    if (m.device_memory_bytes > 0 && total > m.device_memory_bytes) {
        throw Error("scene too large for " + where + ": needs " + human_bytes(total) + " of " +
                    human_bytes(m.device_memory_bytes) + " device memory");
    }
}

AccumLayout accum_layout_for(const GpuScene& scene, int width, int height, const MemoryLimits& m,
                             bool exact_sums) {
    const uint64_t npix = uint64_t(width) * uint64_t(height);
    const AccumLayout plain = accum_layout(npix, m.max_buffer_bytes);
    if (!exact_sums) return plain;
    const AccumLayout exact = accum_layout(npix, m.max_buffer_bytes, true);
    if (exact.exact_pixels == 0) return plain;
    if (m.max_allocation_bytes > 0 && exact.bytes > m.max_allocation_bytes) return plain;
    uint64_t total = exact.bytes - plain.bytes;
    for (const auto& [what, bytes] : device_buffers(scene, width, height, m.max_buffer_bytes))
        total += bytes;
    if (m.device_memory_bytes > 0 && total > m.device_memory_bytes / 2) return plain;
    return exact;
}

void limit_buffers(MemoryLimits& m, uint64_t max_buffer_bytes) {
    if (max_buffer_bytes == 0) return;
    if (m.max_buffer_bytes == 0 || max_buffer_bytes < m.max_buffer_bytes) {
        m.max_buffer_bytes = max_buffer_bytes;
        m.max_buffer_note = " (lowered by BackendOptions::max_buffer_bytes)";
    }
}

}  // namespace mcpt
