// Vulkan backend (the port): device discovery, compute pipeline from the SPIR-V embedded at
// build time, buffer upload, dispatch and read-back. Vulkan 1.1 core, and with --tree rayquery
// or raypipeline Vulkan 1.2 with VK_KHR_ray_query or VK_KHR_ray_tracing_pipeline (acceleration
// structures: vk_accel.h; the pipeline: vk_ray_pipeline.h); the loader is opened at run time,
// so mcpt runs (OpenCL only) where no Vulkan is installed.
//
// Environment:
//   MCPT_VULKAN_VALIDATION=1          enable VK_LAYER_KHRONOS_validation and count its
//                                     warnings and errors (printed to stderr)
//   MCPT_VULKAN_MAX_BUFFER_BYTES=N    lower the effective maxStorageBufferRange to N bytes
//                                     (tests of the "scene too large" path)
//   MCPT_VULKAN_LIMITS=phone          the limits profile when BackendOptions::limits is ""
//                                     (vk_limits_profile.h, docs/limits.md)
//   MCPT_VULKAN_MAX_GROUP_COUNT=N     lower the effective maxComputeWorkGroupCount[0] to N
//                                     (tests of dispatches split into pixel ranges)
//   XDG_CACHE_HOME / HOME             the pipeline cache lives in $XDG_CACHE_HOME/mcpt or
//                                     ~/.cache/mcpt
//   MCPT_VULKAN_WORKGROUP=N           specialize another workgroup size (measurements)
//   MCPT_VULKAN_STATISTICS=1          the driver's pipeline statistics in layout() (registers:
//                                     VK_KHR_pipeline_executable_properties)
#pragma once
#include <memory>
#include <vector>

#include "common/render/backend.h"

namespace mcpt {

// Every Vulkan physical device; an empty list if there is no loader, ICD or device.
std::vector<DeviceInfo> list_vulkan_devices();

// Opens the device chosen by options.device ("" = first discrete or integrated GPU, else the
// first device; an index into list_vulkan_devices(); or a case-insensitive substring of the
// device or driver name). Throws mcpt::Error if none matches. options.fast_math and
// options.extra_defines are refused: the shader is SPIR-V compiled at build time.
std::unique_ptr<Backend> make_vulkan_backend(const BackendOptions& options);

// The concrete backend, for what the Backend interface does not carry (tests, benchmarks):
// dynamic_cast a make_vulkan_backend() result to it.
class VulkanBackend final : public Backend {
  public:
    struct Impl;
    explicit VulkanBackend(std::unique_ptr<Impl> impl);
    ~VulkanBackend() override;

    std::string description() const override;
    const DeviceInfo& device() const override;
    void load(const GpuScene& scene, int width, int height, bool exact_sums) override;
    const AccumLayout& accum_shape() const override;
    uint32_t dispatch(const gpu::GpuParams& params) override;
    void write_plan(const std::vector<uint32_t>& words) override;
    void read_accum(std::vector<float>& out, uint32_t pixels) override;
    void read_exact(std::vector<uint32_t>& out, uint32_t first, uint32_t count) override;
    // Seconds spent creating the compute pipeline in load().
    double compile_seconds() const override;
    uint32_t compiled_features() const override;
    double device_seconds() const override { return gpu_seconds(); }
    uint32_t max_bounces_per_dispatch() const override;
    std::string layout() const override;
    std::string build_settings() const override;
    DeviceBuild device_build() const override;

    // Whether the queue has timestamps (timestampValidBits > 0); gpu_seconds() is 0 if not.
    bool has_gpu_timer() const;
    // Device time of all dispatches so far, from timestamp queries around each one.
    double gpu_seconds() const;
    // Validation-layer warnings and errors so far (0 unless MCPT_VULKAN_VALIDATION=1).
    size_t validation_messages() const;
    // Workgroup size along x that the pipeline was specialized with.
    uint32_t local_size() const;

  private:
    std::string statistics_note() const;
    std::unique_ptr<Impl> impl_;
};

}  // namespace mcpt
