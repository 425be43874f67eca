#include "vulkan/vk_limits_profile.h"

#include <algorithm>
#include <cstdlib>

#include "common/env_integer.h"
#include "common/error.h"
#include "common/gpu/shared_types.h"

namespace mcpt::vk {

std::string resolve_limits_profile(const std::string& requested) {
    std::string p = requested;
    if (p.empty()) {
        const char* e = std::getenv("MCPT_VULKAN_LIMITS");
        p = e && *e ? e : "device";
    }
    if (p != "device" && p != "phone") {
        throw Error("unknown limits profile '" + p + "' (valid: device, phone)");
    }
    return p;
}

void apply_limits_profile(PhysicalDevice& d, const std::string& profile) {
    d.limits_profile = profile;
    if (profile != "phone") return;
    // Vulkan 1.1 required minimums (specification, "Required Limits"; docs/limits.md).
    VkPhysicalDeviceLimits& l = d.props.limits;
    auto clamp = [](uint32_t& v, uint32_t most) { v = std::min(v, most); };
    clamp(l.maxPerStageDescriptorStorageBuffers, 4);
    clamp(l.maxPerStageDescriptorUniformBuffers, 12);
    clamp(l.maxPerStageDescriptorSampledImages, 16);
    clamp(l.maxTexelBufferElements, 65536);
    clamp(l.maxBoundDescriptorSets, 4);
    clamp(l.maxComputeWorkGroupInvocations, 128);
    clamp(l.maxComputeWorkGroupSize[0], 128);
    clamp(l.maxComputeWorkGroupSize[1], 128);
    clamp(l.maxComputeWorkGroupSize[2], 64);
    for (uint32_t& c : l.maxComputeWorkGroupCount) clamp(c, 65535);
    clamp(l.maxComputeSharedMemorySize, 16384);
    clamp(l.maxStorageBufferRange, 1u << 27);  // 128 MiB
    clamp(l.maxUniformBufferRange, 16384);
    clamp(l.maxPushConstantsSize, 128);
    d.max_allocation = std::min<uint64_t>(d.max_allocation ? d.max_allocation : ~0ull, 1ull << 30);
}

uint32_t workgroup_size(const VkPhysicalDeviceLimits& l) {
    const uint32_t most = std::min(l.maxComputeWorkGroupSize[0], l.maxComputeWorkGroupInvocations);
    // $MCPT_VULKAN_WORKGROUP: another size, for measurements (how the driver allocates
    // registers for it), within the device's limits.
    if (const std::optional<long> n = env_integer("MCPT_VULKAN_WORKGROUP", 1, long(most)))
        return uint32_t(*n);
    return std::max(1u, std::min(uint32_t(WORKGROUP_SIZE), most));
}

std::string layout_line(const VkPhysicalDeviceLimits& l) {
    return std::to_string(STORAGE_BUFFER_COUNT) + " storage buffers per stage (device allows " +
           std::to_string(l.maxPerStageDescriptorStorageBuffers) + "), workgroup " +
           std::to_string(workgroup_size(l));
}

void check_layout(const VkPhysicalDeviceLimits& l, const std::string& device) {
    auto refuse = [&](const std::string& what, uint64_t need, const char* limit, uint64_t has) {
        throw Error(device + ": the shader needs " + std::to_string(need) + " " + what + ", " +
                    limit + " is " + std::to_string(has));
    };
    if (l.maxPerStageDescriptorStorageBuffers < STORAGE_BUFFER_COUNT)
        refuse("storage buffers per stage", STORAGE_BUFFER_COUNT,
               "maxPerStageDescriptorStorageBuffers", l.maxPerStageDescriptorStorageBuffers);
    if (l.maxPerStageDescriptorSampledImages < TEXEL_BUFFER_COUNT)
        refuse("texel buffers per stage", TEXEL_BUFFER_COUNT, "maxPerStageDescriptorSampledImages",
               l.maxPerStageDescriptorSampledImages);
    if (l.maxPerStageDescriptorUniformBuffers < 1)
        refuse("uniform buffer", 1, "maxPerStageDescriptorUniformBuffers",
               l.maxPerStageDescriptorUniformBuffers);
    if (l.maxBoundDescriptorSets < 1)
        refuse("descriptor set", 1, "maxBoundDescriptorSets", l.maxBoundDescriptorSets);
    if (l.maxUniformBufferRange < sizeof(gpu::GpuParams))
        refuse("bytes of uniform buffer", sizeof(gpu::GpuParams), "maxUniformBufferRange",
               l.maxUniformBufferRange);
}

}  // namespace mcpt::vk
