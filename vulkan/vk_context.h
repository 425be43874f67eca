// Vulkan plumbing shared by the backend and the device list (private to vulkan/): the loader
// opened at run time, function tables, result checks, the instance with its optional
// validation messenger, and physical-device discovery (limits, and whether ray queries and the
// ray-tracing pipeline are usable).
#pragma once
#ifndef VK_NO_PROTOTYPES
#define VK_NO_PROTOTYPES
#endif
#include <vulkan/vulkan.h>

#include <atomic>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "common/render/backend.h"
#include "common/render/device_limits.h"

namespace mcpt::vk {

// Functions reached through vkGetInstanceProcAddr(instance, ...).
#define MCPT_VK_INSTANCE_FUNCTIONS(X)           \
    X(vkDestroyInstance)                        \
    X(vkEnumeratePhysicalDevices)               \
    X(vkGetPhysicalDeviceProperties)            \
    X(vkGetPhysicalDeviceProperties2)           \
    X(vkGetPhysicalDeviceFeatures2)             \
    X(vkGetPhysicalDeviceQueueFamilyProperties) \
    X(vkGetPhysicalDeviceMemoryProperties)      \
    X(vkGetPhysicalDeviceFormatProperties)      \
    X(vkEnumerateDeviceExtensionProperties)     \
    X(vkCreateDevice)                           \
    X(vkGetDeviceProcAddr)

// Functions reached through vkGetDeviceProcAddr(device, ...).
#define MCPT_VK_DEVICE_FUNCTIONS(X)  \
    X(vkDestroyDevice)               \
    X(vkGetDeviceQueue)              \
    X(vkDeviceWaitIdle)              \
    X(vkCreateBuffer)                \
    X(vkDestroyBuffer)               \
    X(vkCreateBufferView)            \
    X(vkDestroyBufferView)           \
    X(vkGetBufferMemoryRequirements) \
    X(vkAllocateMemory)              \
    X(vkFreeMemory)                  \
    X(vkBindBufferMemory)            \
    X(vkMapMemory)                   \
    X(vkUnmapMemory)                 \
    X(vkCreateShaderModule)          \
    X(vkDestroyShaderModule)         \
    X(vkCreatePipelineCache)         \
    X(vkDestroyPipelineCache)        \
    X(vkGetPipelineCacheData)        \
    X(vkCreateComputePipelines)      \
    X(vkDestroyPipeline)             \
    X(vkCreateDescriptorSetLayout)   \
    X(vkDestroyDescriptorSetLayout)  \
    X(vkCreatePipelineLayout)        \
    X(vkDestroyPipelineLayout)       \
    X(vkCreateDescriptorPool)        \
    X(vkDestroyDescriptorPool)       \
    X(vkAllocateDescriptorSets)      \
    X(vkUpdateDescriptorSets)        \
    X(vkCreateCommandPool)           \
    X(vkDestroyCommandPool)          \
    X(vkResetCommandPool)            \
    X(vkAllocateCommandBuffers)      \
    X(vkBeginCommandBuffer)          \
    X(vkEndCommandBuffer)            \
    X(vkCmdBindPipeline)             \
    X(vkCmdBindDescriptorSets)       \
    X(vkCmdDispatch)                 \
    X(vkCmdPipelineBarrier)          \
    X(vkCmdCopyBuffer)               \
    X(vkCmdFillBuffer)               \
    X(vkCmdResetQueryPool)           \
    X(vkCmdWriteTimestamp)           \
    X(vkCreateQueryPool)             \
    X(vkDestroyQueryPool)            \
    X(vkGetQueryPoolResults)         \
    X(vkCreateFence)                 \
    X(vkDestroyFence)                \
    X(vkResetFences)                 \
    X(vkWaitForFences)               \
    X(vkQueueSubmit)

// Buffer device addresses and acceleration structures: loaded only on a device created with
// ray queries or the ray-tracing pipeline (PhysicalDevice::accel()).
#define MCPT_VK_ACCEL_FUNCTIONS(X)                   \
    X(vkGetBufferDeviceAddress)                      \
    X(vkCreateAccelerationStructureKHR)              \
    X(vkDestroyAccelerationStructureKHR)             \
    X(vkGetAccelerationStructureBuildSizesKHR)       \
    X(vkCmdBuildAccelerationStructuresKHR)           \
    X(vkGetAccelerationStructureDeviceAddressKHR)    \
    X(vkCmdWriteAccelerationStructuresPropertiesKHR) \
    X(vkCmdCopyAccelerationStructureKHR)
// The ray-tracing pipeline's: loaded where PhysicalDevice::ray_pipeline.
#define MCPT_VK_RAY_PIPELINE_FUNCTIONS(X)   \
    X(vkCreateRayTracingPipelinesKHR)       \
    X(vkGetRayTracingShaderGroupHandlesKHR) \
    X(vkCmdTraceRaysKHR)

#define MCPT_VK_DECLARE(name) PFN_##name name = nullptr;
struct InstanceFns {
    MCPT_VK_INSTANCE_FUNCTIONS(MCPT_VK_DECLARE)
    // VK_EXT_debug_utils, only with validation.
    PFN_vkCreateDebugUtilsMessengerEXT vkCreateDebugUtilsMessengerEXT = nullptr;
    PFN_vkDestroyDebugUtilsMessengerEXT vkDestroyDebugUtilsMessengerEXT = nullptr;
};
struct DeviceFns {
    MCPT_VK_DEVICE_FUNCTIONS(MCPT_VK_DECLARE)
};
struct AccelFns {
    MCPT_VK_ACCEL_FUNCTIONS(MCPT_VK_DECLARE)
};
struct RayPipelineFns {
    MCPT_VK_RAY_PIPELINE_FUNCTIONS(MCPT_VK_DECLARE)
};
#undef MCPT_VK_DECLARE

// The message of every "no Vulkan" failure.
inline constexpr const char* kNoDeviceMessage =
    "no Vulkan device found (install mesa-vulkan-drivers for lavapipe)";

// "VK_ERROR_OUT_OF_DEVICE_MEMORY".
const char* result_name(VkResult r);
// Throws mcpt::Error("<call> failed: <result>") unless r is VK_SUCCESS (or VK_INCOMPLETE);
// mcpt::DeviceLost for VK_ERROR_DEVICE_LOST.
void check(VkResult r, const char* call);
// check() with the call's name taken from the expression: VK_CHECK(f.vkCreateBuffer, ...).
#define VK_CHECK(fn, ...) ::mcpt::vk::check(fn(__VA_ARGS__), ::mcpt::vk::call_name(#fn))
const char* call_name(const char* expr);  // "f.vkCreateBuffer" -> "vkCreateBuffer"

std::string lower(std::string s);
std::string version_string(uint32_t v);  // "1.3.230"

// A physical device with what the backend needs to choose and size it.
struct PhysicalDevice {
    VkPhysicalDevice handle = VK_NULL_HANDLE;
    DeviceInfo info;
    VkPhysicalDeviceProperties props{};
    VkPhysicalDeviceMemoryProperties memory{};
    uint64_t max_allocation = 0;            // maxMemoryAllocationSize (maintenance3, core 1.1)
    uint32_t queue_family = UINT32_MAX;     // first family with compute, UINT32_MAX if none
    uint32_t timestamp_valid_bits = 0;      // of that family
    std::string limits_profile = "device";  // vk_limits_profile.h: what props.limits hold
    // Ray queries usable (--tree rayquery): Vulkan 1.2, VK_KHR_acceleration_structure,
    // VK_KHR_ray_query and VK_KHR_deferred_host_operations, with their features and
    // bufferDeviceAddress; the device is then created with them.
    bool ray_query = false;
    std::string ray_query_note;  // why not, or "yes"
    // The ray-tracing pipeline usable (--tree raypipeline): the same with
    // VK_KHR_ray_tracing_pipeline instead of VK_KHR_ray_query (NVIDIA's H100 driver has only
    // this one).
    bool ray_pipeline = false;
    std::string ray_pipeline_note;
    // The driver's statistics of a compiled pipeline (registers, code size: whatever it
    // reports) can be asked for: VK_KHR_pipeline_executable_properties and its feature.
    bool pipeline_statistics = false;
    VkPhysicalDeviceAccelerationStructurePropertiesKHR accel_props{};  // where accel()
    VkPhysicalDeviceRayTracingPipelinePropertiesKHR rt_props{};        // where ray_pipeline
    // Acceleration structures: either way of tracing through them.
    bool accel() const { return ray_query || ray_pipeline; }
};

// The device extensions each way of tracing takes (besides Vulkan 1.2's buffer device
// addresses).
inline constexpr const char* kAccelExtensions[] = {"VK_KHR_acceleration_structure",
                                                   "VK_KHR_deferred_host_operations"};
inline constexpr const char* kRayQueryExtension = "VK_KHR_ray_query";
inline constexpr const char* kRayPipelineExtension = "VK_KHR_ray_tracing_pipeline";
inline constexpr const char* kPipelineStatisticsExtension = "VK_KHR_pipeline_executable_properties";

// $MCPT_VULKAN_STATISTICS=1: devices are created with kPipelineStatisticsExtension where they
// have it, pipelines capture the driver's statistics, and `render -v` prints them (a
// measurement: capturing may cost the driver's pipeline cache). Unset or 0: neither. Any other
// value throws mcpt::Error.
bool pipeline_statistics_wanted();

// The buffer limits of a device for check_device_limits(), with MCPT_VULKAN_MAX_BUFFER_BYTES
// applied as the environment says now.
MemoryLimits memory_limits(const PhysicalDevice& d);

// A Vulkan 1.2 instance (1.1 devices keep 1.1); with validation, VK_LAYER_KHRONOS_validation and a
// debug-utils messenger counting warnings and errors.
class Instance {
  public:
    // Throws mcpt::Error(kNoDeviceMessage) without a loader or ICD; with validation, throws
    // if the layer or VK_EXT_debug_utils is missing.
    explicit Instance(bool validation);
    ~Instance();
    Instance(const Instance&) = delete;
    Instance& operator=(const Instance&) = delete;

    VkInstance handle() const { return instance_; }
    const InstanceFns& fn() const { return fn_; }
    size_t messages() const { return messages_.load(); }
    // Every physical device, in enumeration order (DeviceInfo::index), with its limits
    // clamped to the limits profile (vk_limits_profile.h; "" = $MCPT_VULKAN_LIMITS or device).
    std::vector<PhysicalDevice> devices(const std::string& profile = "") const;

  private:
    void probe_driver_tracing(PhysicalDevice& d, const std::vector<std::string>& extensions) const;
    static VKAPI_ATTR VkBool32 VKAPI_CALL on_message(
        VkDebugUtilsMessageSeverityFlagBitsEXT severity, VkDebugUtilsMessageTypeFlagsEXT types,
        const VkDebugUtilsMessengerCallbackDataEXT* data, void* user);

    VkInstance instance_ = VK_NULL_HANDLE;
    VkDebugUtilsMessengerEXT messenger_ = VK_NULL_HANDLE;
    InstanceFns fn_;
    std::atomic<size_t> messages_{0};
};

// The process's instance for this validation setting, created on first use and kept: drivers
// cap how many instances a process may create (NVIDIA 580 fails after about 30), and
// creating one takes a tenth of a second. Thread-safe.
std::shared_ptr<Instance> shared_instance(bool validation);

// Whether MCPT_VULKAN_VALIDATION=1.
bool validation_requested();
// An unsigned environment override (e.g. MCPT_VULKAN_MAX_BUFFER_BYTES), or `fallback`.
uint64_t env_limit(const char* name, uint64_t fallback);

}  // namespace mcpt::vk
