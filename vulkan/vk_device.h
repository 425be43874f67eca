// A logical device for compute (private to vulkan/): one queue, one reusable command buffer
// with a fence, buffers with their own allocations (with device addresses where asked), the
// acceleration-structure and ray-tracing-pipeline functions where the device has them, the
// driver's pipeline statistics where asked for, and the on-disk pipeline cache file.
#pragma once
#include <string>
#include <vector>

#include "vulkan/vk_context.h"

namespace mcpt::vk {

constexpr VkMemoryPropertyFlags kHostMemory =
    VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT;

// A buffer with its own allocation; `mapped` is set when the memory is host-visible and
// coherent (then the host reads and writes it directly).
struct Buffer {
    VkBuffer buffer = VK_NULL_HANDLE;
    VkDeviceMemory memory = VK_NULL_HANDLE;
    void* mapped = nullptr;
    VkDeviceSize size = 0;
};

class Device {
  public:
    // Creates the device with one queue of pd.queue_family, and with ray queries and the
    // ray-tracing pipeline where pd has them; `name` goes into error messages.
    Device(const Instance& instance, const PhysicalDevice& pd, std::string name);
    ~Device();
    Device(const Device&) = delete;
    Device& operator=(const Device&) = delete;

    const DeviceFns& fn() const { return f_; }
    // The acceleration-structure functions; null on a device without ray queries or the
    // ray-tracing pipeline.
    const AccelFns* accel() const { return accel_ ? &accel_fns_ : nullptr; }
    // The ray-tracing pipeline's functions; null on a device without it.
    const RayPipelineFns* rt() const { return rt_ ? &rt_fns_ : nullptr; }
    VkDevice handle() const { return device_; }
    // Pipelines capture the driver's statistics (pipeline_statistics_wanted() and the device
    // has them: VK_PIPELINE_CREATE_CAPTURE_STATISTICS_BIT_KHR goes into their flags).
    bool statistics() const { return statistics_; }
    // The driver's statistics of a pipeline created with that flag, "name value, ..." (its
    // names: "Register Count", "Binary Size", ...); "" without them.
    std::string pipeline_statistics(VkPipeline pipeline) const;
    VkCommandBuffer cmd() const { return cmd_; }
    // The pipeline stages shaders read and write the scene in: compute, and ray tracing where
    // the device was created with the pipeline (barriers name only stages a device has).
    VkPipelineStageFlags shader_stages() const {
        return VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT |
               (rt_ ? VK_PIPELINE_STAGE_RAY_TRACING_SHADER_BIT_KHR : 0);
    }

    // A buffer in the first memory type with required | preferred flags, else required (with
    // a device address where usage asks for one).
    Buffer create_buffer(VkDeviceSize size, VkBufferUsageFlags usage,
                         VkMemoryPropertyFlags required, VkMemoryPropertyFlags preferred);
    void free_buffer(Buffer& b);
    // A device-local storage buffer (with these further usages) holding these bytes, through a
    // staging buffer when that memory is not host-visible.
    Buffer upload(const void* data, size_t bytes, VkBufferUsageFlags more_usage = 0);

    // Resets and begins cmd(); submit_and_wait() ends, submits and waits on the fence.
    void begin_commands();
    void submit_and_wait();
    // A global memory barrier recorded into cmd().
    void barrier(VkPipelineStageFlags src_stage, VkAccessFlags src, VkPipelineStageFlags dst_stage,
                 VkAccessFlags dst);
    void wait_idle();

  private:
    void destroy();

    VkPhysicalDeviceMemoryProperties memory_;
    std::string name_;
    DeviceFns f_;
    bool accel_ = false, rt_ = false;
    AccelFns accel_fns_;
    RayPipelineFns rt_fns_;
    bool statistics_ = false;
    PFN_vkGetPipelineExecutablePropertiesKHR get_executables_ = nullptr;
    PFN_vkGetPipelineExecutableStatisticsKHR get_statistics_ = nullptr;
    VkDevice device_ = VK_NULL_HANDLE;
    VkQueue queue_ = VK_NULL_HANDLE;
    VkCommandPool pool_ = VK_NULL_HANDLE;
    VkCommandBuffer cmd_ = VK_NULL_HANDLE;
    VkFence fence_ = VK_NULL_HANDLE;
};

// $XDG_CACHE_HOME/mcpt/vk_pipeline_cache_<vendor>_<device>.bin (else under ~/.cache); empty
// if neither variable is set.
std::string pipeline_cache_path(const VkPhysicalDeviceProperties& props);
// The file's bytes if its header matches this device and driver, else empty; a file that
// exists but cannot be read is a warning on stderr.
std::vector<char> read_pipeline_cache(const std::string& path,
                                      const VkPhysicalDeviceProperties& props);
// Writes through a temporary file and a rename, so concurrent runs never read half a file;
// failure is a warning on stderr.
void write_pipeline_cache(const std::string& path, const std::vector<char>& data);

}  // namespace mcpt::vk
