// Limits profiles: what the Vulkan backend may use of a device. "device" takes the device's
// own limits; "phone" clamps every limit the backend reads to the minimum the Vulkan 1.1
// specification requires of every device (the table in docs/limits.md), so a desktop or
// lavapipe exercises what a baseline Android phone guarantees.
#pragma once
#include <string>

#include "vulkan/vk_context.h"

namespace mcpt::vk {

// The profile to use: `requested` if not empty, else $MCPT_VULKAN_LIMITS, else "device".
// Throws mcpt::Error for an unknown name.
std::string resolve_limits_profile(const std::string& requested);

// Clamps d's limits (props.limits, max_allocation) to `profile` ("device" leaves them) and
// records the profile in d.limits_profile.
void apply_limits_profile(PhysicalDevice& d, const std::string& profile);

// The workgroup size along x the backend specializes the shader with on such a device.
uint32_t workgroup_size(const VkPhysicalDeviceLimits& limits);

// What the backend works within there: "4 storage buffers per stage (device allows 4),
// workgroup 64".
std::string layout_line(const VkPhysicalDeviceLimits& limits);

// Throws mcpt::Error naming the limit if the shader's bindings do not fit the device.
void check_layout(const VkPhysicalDeviceLimits& limits, const std::string& device);

}  // namespace mcpt::vk
