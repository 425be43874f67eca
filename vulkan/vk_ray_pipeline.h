// The ray-tracing pipeline (private to vulkan/; --tree raypipeline): pathtrace.comp built as
// its ray-generation shader, the miss shader and two hit groups of shaders/trace_hits.glsl
// (triangles: closest hit, and any hit for cut-outs; spheres: closest hit, and our sphere
// test as the intersection shader), and the shader binding table naming them. A launch is one
// invocation per pixel of the dispatch's range, as the compute form's one per pixel.
#pragma once
#include <cstdint>

#include "vulkan/vk_device.h"

namespace mcpt::vk {

// The hit groups' order in the binding table: the top level's instance of each bottom-level
// structure names its group (vk_accel.cpp).
constexpr uint32_t kTriangleHitGroup = 0;
constexpr uint32_t kSphereHitGroup = 1;

class RayPipeline {
  public:
    RayPipeline() = default;
    ~RayPipeline() { release(); }
    RayPipeline(const RayPipeline&) = delete;
    RayPipeline& operator=(const RayPipeline&) = delete;

    // Creates the pipeline (its modules on first use) with this layout and every stage
    // specialized alike, and its binding table; replaces what an earlier build made. Throws
    // mcpt::Error.
    void build(Device& dev, const PhysicalDevice& pd, VkPipelineLayout layout,
               const VkSpecializationInfo& spec, VkPipelineCache cache);
    void release();

    VkPipeline handle() const { return pipeline_; }
    // Records a launch of `count` invocations (gl_LaunchIDEXT.x) into the device's command
    // buffer, the pipeline and its descriptor set bound.
    void trace(uint32_t count) const;
    // The most invocations one launch may have on pd.
    static uint64_t max_launch(const PhysicalDevice& pd);

  private:
    void destroy_pipeline();

    Device* dev_ = nullptr;
    VkShaderModule modules_[5] = {};
    VkPipeline pipeline_ = VK_NULL_HANDLE;
    Buffer table_;  // the shader binding table (host-visible)
    VkStridedDeviceAddressRegionKHR raygen_{}, miss_{}, hit_{}, callable_{};
};

}  // namespace mcpt::vk
