#include "vulkan/vk_ray_pipeline.h"

#include <algorithm>
#include <cstring>
#include <vector>

#include "common/error.h"
#include "pathtrace_raygen_spv.h"
#include "trace_any_hit_spv.h"
#include "trace_closest_hit_spv.h"
#include "trace_miss_spv.h"
#include "trace_sphere_spv.h"

namespace mcpt::vk {

namespace {

// The stages, in the order of RayPipeline::modules_.
enum Stage : uint32_t { kRaygen, kMiss, kClosestHit, kAnyHit, kSphere, kStageCount };

uint64_t align_up(uint64_t x, uint64_t a) {
    return a > 1 ? (x + a - 1) / a * a : x;
}

}  // namespace

uint64_t RayPipeline::max_launch(const PhysicalDevice& pd) {
    const VkPhysicalDeviceLimits& l = pd.props.limits;
    return std::min<uint64_t>(
        uint64_t(l.maxComputeWorkGroupCount[0]) * l.maxComputeWorkGroupSize[0],
        pd.rt_props.maxRayDispatchInvocationCount);
}

void RayPipeline::destroy_pipeline() {
    if (!dev_) return;
    if (pipeline_) dev_->fn().vkDestroyPipeline(dev_->handle(), pipeline_, nullptr);
    pipeline_ = VK_NULL_HANDLE;
    dev_->free_buffer(table_);
}

void RayPipeline::release() {
    if (!dev_) return;
    destroy_pipeline();
    for (VkShaderModule& m : modules_) {
        if (m) dev_->fn().vkDestroyShaderModule(dev_->handle(), m, nullptr);
        m = VK_NULL_HANDLE;
    }
    dev_ = nullptr;
}

void RayPipeline::build(Device& dev, const PhysicalDevice& pd, VkPipelineLayout layout,
                        const VkSpecializationInfo& spec, VkPipelineCache cache) {
    if (!dev.rt() || !dev.accel())
        throw Error("vulkan: " + pd.info.name + " has no ray-tracing pipeline");
    if (dev_ && dev_ != &dev) release();
    destroy_pipeline();
    dev_ = &dev;
    const VkDevice device = dev.handle();
    const vk::DeviceFns& f = dev.fn();

    // The modules, from the SPIR-V embedded at build time.
    static const struct {
        const uint32_t* code;
        size_t bytes;
        VkShaderStageFlagBits stage;
    } kModules[kStageCount] = {
        {kPathtraceRaygenSpirv, sizeof(kPathtraceRaygenSpirv), VK_SHADER_STAGE_RAYGEN_BIT_KHR},
        {kTraceMissSpirv, sizeof(kTraceMissSpirv), VK_SHADER_STAGE_MISS_BIT_KHR},
        {kTraceClosestHitSpirv, sizeof(kTraceClosestHitSpirv), VK_SHADER_STAGE_CLOSEST_HIT_BIT_KHR},
        {kTraceAnyHitSpirv, sizeof(kTraceAnyHitSpirv), VK_SHADER_STAGE_ANY_HIT_BIT_KHR},
        {kTraceSphereSpirv, sizeof(kTraceSphereSpirv), VK_SHADER_STAGE_INTERSECTION_BIT_KHR},
    };
    VkPipelineShaderStageCreateInfo stages[kStageCount]{};
    for (uint32_t i = 0; i < kStageCount; ++i) {
        if (!modules_[i]) {
            VkShaderModuleCreateInfo si{};
            si.sType = VK_STRUCTURE_TYPE_SHADER_MODULE_CREATE_INFO;
            si.codeSize = kModules[i].bytes;
            si.pCode = kModules[i].code;
            VK_CHECK(f.vkCreateShaderModule, device, &si, nullptr, &modules_[i]);
        }
        stages[i].sType = VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO;
        stages[i].stage = kModules[i].stage;
        stages[i].module = modules_[i];
        stages[i].pName = "main";
        stages[i].pSpecializationInfo = &spec;
    }

    // Groups: ray generation, miss, then the hit groups (kTriangleHitGroup, kSphereHitGroup).
    VkRayTracingShaderGroupCreateInfoKHR groups[4]{};
    for (VkRayTracingShaderGroupCreateInfoKHR& g : groups) {
        g.sType = VK_STRUCTURE_TYPE_RAY_TRACING_SHADER_GROUP_CREATE_INFO_KHR;
        g.generalShader = g.closestHitShader = g.anyHitShader = g.intersectionShader =
            VK_SHADER_UNUSED_KHR;
    }
    groups[0].type = groups[1].type = VK_RAY_TRACING_SHADER_GROUP_TYPE_GENERAL_KHR;
    groups[0].generalShader = kRaygen;
    groups[1].generalShader = kMiss;
    VkRayTracingShaderGroupCreateInfoKHR& tri = groups[2 + kTriangleHitGroup];
    tri.type = VK_RAY_TRACING_SHADER_GROUP_TYPE_TRIANGLES_HIT_GROUP_KHR;
    tri.closestHitShader = kClosestHit;
    tri.anyHitShader = kAnyHit;
    VkRayTracingShaderGroupCreateInfoKHR& sphere = groups[2 + kSphereHitGroup];
    sphere.type = VK_RAY_TRACING_SHADER_GROUP_TYPE_PROCEDURAL_HIT_GROUP_KHR;
    sphere.closestHitShader = kClosestHit;
    sphere.intersectionShader = kSphere;

    // The pipeline: the ray-generation shader traces, nothing else does (depth 1).
    VkRayTracingPipelineCreateInfoKHR ci{};
    ci.sType = VK_STRUCTURE_TYPE_RAY_TRACING_PIPELINE_CREATE_INFO_KHR;
    ci.stageCount = kStageCount;
    ci.pStages = stages;
    ci.groupCount = uint32_t(std::size(groups));
    ci.pGroups = groups;
    ci.maxPipelineRayRecursionDepth = 1;
    ci.layout = layout;
    VK_CHECK(dev.rt()->vkCreateRayTracingPipelinesKHR, device, VK_NULL_HANDLE, cache, 1, &ci,
             nullptr, &pipeline_);

    // The binding table: each region starts on the base alignment, its records on the handle
    // alignment; the ray-generation region is one record, its size its stride.
    const VkPhysicalDeviceRayTracingPipelinePropertiesKHR& rt = pd.rt_props;
    const uint32_t handle = rt.shaderGroupHandleSize;
    const uint64_t base = std::max<uint64_t>(1, rt.shaderGroupBaseAlignment);
    const uint64_t stride = align_up(handle, rt.shaderGroupHandleAlignment);
    std::vector<uint8_t> handles(size_t(handle) * ci.groupCount);
    VK_CHECK(dev.rt()->vkGetRayTracingShaderGroupHandlesKHR, device, pipeline_, 0, ci.groupCount,
             handles.size(), handles.data());
    const uint64_t raygen_at = 0;
    const uint64_t miss_at = align_up(raygen_at + align_up(stride, base), base);
    const uint64_t hit_at = align_up(miss_at + stride, base);
    const uint64_t bytes = hit_at + 2 * stride;
    table_ = dev.create_buffer(
        bytes + base,
        VK_BUFFER_USAGE_SHADER_BINDING_TABLE_BIT_KHR | VK_BUFFER_USAGE_SHADER_DEVICE_ADDRESS_BIT,
        kHostMemory, 0);
    VkBufferDeviceAddressInfo ai{};
    ai.sType = VK_STRUCTURE_TYPE_BUFFER_DEVICE_ADDRESS_INFO;
    ai.buffer = table_.buffer;
    const VkDeviceAddress address = dev.accel()->vkGetBufferDeviceAddress(device, &ai);
    const VkDeviceAddress start = align_up(address, base);
    uint8_t* at = static_cast<uint8_t*>(table_.mapped) + (start - address);
    std::memcpy(at + raygen_at, &handles[0], handle);
    std::memcpy(at + miss_at, &handles[handle], handle);
    std::memcpy(at + hit_at, &handles[2 * handle], handle);
    std::memcpy(at + hit_at + stride, &handles[3 * handle], handle);
    raygen_ = {start + raygen_at, align_up(stride, base), align_up(stride, base)};
    miss_ = {start + miss_at, stride, stride};
    hit_ = {start + hit_at, stride, 2 * stride};
    callable_ = {};
}

void RayPipeline::trace(uint32_t count) const {
    dev_->rt()->vkCmdTraceRaysKHR(dev_->cmd(), &raygen_, &miss_, &hit_, &callable_, count, 1, 1);
}

}  // namespace mcpt::vk
