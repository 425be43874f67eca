// One check of a scene against a device's memory limits, for both APIs: every device buffer
// against the largest bindable buffer and allocation, and their total against the device's
// memory. Backends run it in load(), before compiling or allocating anything.
#pragma once
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "common/io/host_memory.h"
#include "common/render/backend.h"
#include "common/render/gpu_scene.h"

namespace mcpt {

// The device buffers of a scene rendered at width x height on a device whose largest buffer
// is max_buffer_bytes (0 = unknown; the path state fits itself in), named as messages name
// them.
std::vector<std::pair<std::string, uint64_t>> device_buffers(const GpuScene& scene, int width,
                                                             int height, uint64_t max_buffer_bytes);

// The accumulation buffer load() allocates: with room for exact sums (reproducible renders)
// when exact_sums asks and they fit the largest buffer and allocation and, with the scene,
// half of the device's memory; otherwise without (the host then adds the groups exactly).
AccumLayout accum_layout_for(const GpuScene& scene, int width, int height, const MemoryLimits& m,
                             bool exact_sums);

// Lowers m.max_buffer_bytes to max_buffer_bytes (0: leaves it), noting why: how tests make a
// device's largest buffer small (BackendOptions::max_buffer_bytes).
void limit_buffers(MemoryLimits& m, uint64_t max_buffer_bytes);

// Throws mcpt::Error "scene too large for <where>: <buffer> need(s) <size>, <limit> is <size>"
// naming the first buffer over a limit, or the total over the device's memory.
void check_device_limits(const GpuScene& scene, int width, int height, const DeviceInfo& device,
                         const std::string& where);

}  // namespace mcpt
