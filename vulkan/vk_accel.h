// The scene's acceleration structures for the driver's tracing (private to vulkan/; --tree
// rayquery and raypipeline):
// one bottom-level structure over the triangles (primitive i is triangle i), one over a box
// per sphere (procedural: the shader tests the sphere), and a top-level structure over both,
// built on the device once per loaded scene, compacted, and never rebuilt per frame.
#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include "common/gpu/shared_types.h"
#include "vulkan/vk_device.h"

namespace mcpt::vk {

// What a build made: seconds (host wall time, upload to compaction), bytes kept on the device
// (after compaction), bytes of scratch and input the build took and released.
struct AccelStats {
    double build_seconds = 0;
    uint64_t bytes = 0;
    uint64_t transient_bytes = 0;
    bool compacted = false;
};

// Consecutive triangles that are all opaque, or all cut out where their material's alpha mask
// says (each run a bottom-level structure of its own: only cut-out runs call on the shader).
struct TriangleRun {
    uint32_t first = 0, count = 0;
    bool cut_out = false;
};
// At most kMaxTriangleRuns runs (instances in the top level); a scene that would need more,
// or whose last run begins beyond an instance's 24-bit custom index, gets one run of every
// triangle, cut out if any is.
constexpr size_t kMaxTriangleRuns = 16;
std::vector<TriangleRun> triangle_runs(const std::vector<bool>& cut_out, size_t count);

class SceneAccel {
  public:
    SceneAccel() = default;
    ~SceneAccel() { release(); }
    SceneAccel(const SceneAccel&) = delete;
    SceneAccel& operator=(const SceneAccel&) = delete;

    // Builds the structures of these triangles and spheres on `dev` (created with ray
    // queries or the ray-tracing pipeline); triangle i is opaque unless cut_out[i] (its
    // material has an alpha mask: the shader decides each candidate). Replaces what an
    // earlier build made. Throws mcpt::Error. `fault`: BackendOptions::accel_fault (tests).
    void build(Device& dev, const PhysicalDevice& pd, const std::vector<gpu::GpuTriangle>& tris,
               const std::vector<gpu::GpuSphere>& spheres, const std::vector<bool>& cut_out,
               const std::string& fault = "");
    void release();

    VkAccelerationStructureKHR top() const { return top_.handle; }
    const AccelStats& stats() const { return stats_; }
    // "acceleration structures: 2 bottom-level, 1.2 MB (compacted), built in 3.1 ms".
    std::string describe() const;

  private:
    struct Accel {
        VkAccelerationStructureKHR handle = VK_NULL_HANDLE;
        Buffer buffer;
        VkDeviceAddress address = 0;
    };
    Accel build_one(const VkAccelerationStructureGeometryKHR& geometry, uint32_t count,
                    VkAccelerationStructureTypeKHR type);
    VkDeviceAddress address_of(const Buffer& b) const;
    void destroy(Accel& a);

    Device* dev_ = nullptr;
    const PhysicalDevice* pd_ = nullptr;
    std::vector<Accel> triangle_runs_;  // triangle_runs()
    Accel spheres_, top_;
    AccelStats stats_;
};

}  // namespace mcpt::vk
