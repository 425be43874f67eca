#include "vulkan/vk_accel.h"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <limits>

#include "common/error.h"
#include "common/io/host_memory.h"
#include "vulkan/vk_ray_pipeline.h"

namespace mcpt::vk {

namespace {

constexpr VkBufferUsageFlags kAddress = VK_BUFFER_USAGE_SHADER_DEVICE_ADDRESS_BIT;
constexpr VkBufferUsageFlags kBuildInput =
    VK_BUFFER_USAGE_ACCELERATION_STRUCTURE_BUILD_INPUT_READ_ONLY_BIT_KHR | kAddress;

// A whole-device barrier from acceleration-structure builds (and copies) to their readers.
void after_build(Device& dev) {
    dev.barrier(VK_PIPELINE_STAGE_ACCELERATION_STRUCTURE_BUILD_BIT_KHR,
                VK_ACCESS_ACCELERATION_STRUCTURE_WRITE_BIT_KHR,
                VK_PIPELINE_STAGE_ACCELERATION_STRUCTURE_BUILD_BIT_KHR | dev.shader_stages(),
                VK_ACCESS_ACCELERATION_STRUCTURE_READ_BIT_KHR);
}

}  // namespace

std::vector<TriangleRun> triangle_runs(const std::vector<bool>& cut_out, size_t count) {
    // Runs of equal cut_out; too many of them (or a first index beyond an instance's 24-bit
    // custom index), and one run of all, cut out if any is.
    std::vector<TriangleRun> runs;
    bool any = false;
    for (size_t i = 0; i < count; ++i) {
        const bool c = i < cut_out.size() && cut_out[i];
        any = any || c;
        if (runs.empty() || runs.back().cut_out != c) runs.push_back({uint32_t(i), 0, c});
        runs.back().count += 1;
    }
    if (runs.size() > kMaxTriangleRuns || runs.back().first >= (1u << 24))
        runs = {{0, uint32_t(count), any}};
    return runs;
}

VkDeviceAddress SceneAccel::address_of(const Buffer& b) const {
    VkBufferDeviceAddressInfo ai{};
    ai.sType = VK_STRUCTURE_TYPE_BUFFER_DEVICE_ADDRESS_INFO;
    ai.buffer = b.buffer;
    return dev_->accel()->vkGetBufferDeviceAddress(dev_->handle(), &ai);
}

void SceneAccel::destroy(Accel& a) {
    if (a.handle)
        dev_->accel()->vkDestroyAccelerationStructureKHR(dev_->handle(), a.handle, nullptr);
    dev_->free_buffer(a.buffer);
    a = Accel{};
}

void SceneAccel::release() {
    if (!dev_) return;
    for (Accel* a : {&top_, &spheres_}) destroy(*a);
    for (Accel& a : triangle_runs_) destroy(a);
    triangle_runs_.clear();
    stats_ = AccelStats{};
    dev_ = nullptr;
}

SceneAccel::Accel SceneAccel::build_one(const VkAccelerationStructureGeometryKHR& geometry,
                                        uint32_t count, VkAccelerationStructureTypeKHR type) {
    const AccelFns& rq = *dev_->accel();
    const VkDevice device = dev_->handle();
    // Sizes for this geometry, built for fast tracing and compactable.
    VkAccelerationStructureBuildGeometryInfoKHR bi{};
    bi.sType = VK_STRUCTURE_TYPE_ACCELERATION_STRUCTURE_BUILD_GEOMETRY_INFO_KHR;
    bi.type = type;
    bi.flags = VK_BUILD_ACCELERATION_STRUCTURE_PREFER_FAST_TRACE_BIT_KHR |
               VK_BUILD_ACCELERATION_STRUCTURE_ALLOW_COMPACTION_BIT_KHR;
    bi.mode = VK_BUILD_ACCELERATION_STRUCTURE_MODE_BUILD_KHR;
    bi.geometryCount = 1;
    bi.pGeometries = &geometry;
    VkAccelerationStructureBuildSizesInfoKHR sizes{};
    sizes.sType = VK_STRUCTURE_TYPE_ACCELERATION_STRUCTURE_BUILD_SIZES_INFO_KHR;
    rq.vkGetAccelerationStructureBuildSizesKHR(
        device, VK_ACCELERATION_STRUCTURE_BUILD_TYPE_DEVICE_KHR, &bi, &count, &sizes);

    // The structure's buffer and handle; scratch memory aligned as the device asks.
    Accel a;
    a.buffer =
        dev_->create_buffer(sizes.accelerationStructureSize,
                            VK_BUFFER_USAGE_ACCELERATION_STRUCTURE_STORAGE_BIT_KHR | kAddress, 0,
                            VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT);
    VkAccelerationStructureCreateInfoKHR ci{};
    ci.sType = VK_STRUCTURE_TYPE_ACCELERATION_STRUCTURE_CREATE_INFO_KHR;
    ci.buffer = a.buffer.buffer;
    ci.size = sizes.accelerationStructureSize;
    ci.type = type;
    VK_CHECK(rq.vkCreateAccelerationStructureKHR, device, &ci, nullptr, &a.handle);
    const uint64_t align =
        std::max<uint64_t>(1, pd_->accel_props.minAccelerationStructureScratchOffsetAlignment);
    Buffer scratch = dev_->create_buffer(sizes.buildScratchSize + align,
                                         VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | kAddress, 0,
                                         VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT);
    stats_.transient_bytes += scratch.size;
    VkQueryPool sizes_query = VK_NULL_HANDLE;
    try {
        bi.dstAccelerationStructure = a.handle;
        bi.scratchData.deviceAddress = (address_of(scratch) + align - 1) / align * align;
        VkQueryPoolCreateInfo qi{};
        qi.sType = VK_STRUCTURE_TYPE_QUERY_POOL_CREATE_INFO;
        qi.queryType = VK_QUERY_TYPE_ACCELERATION_STRUCTURE_COMPACTED_SIZE_KHR;
        qi.queryCount = 1;
        VK_CHECK(dev_->fn().vkCreateQueryPool, device, &qi, nullptr, &sizes_query);
        // Build, then ask for the compacted size.
        const VkAccelerationStructureBuildRangeInfoKHR range{count, 0, 0, 0};
        const VkAccelerationStructureBuildRangeInfoKHR* ranges = &range;
        dev_->begin_commands();
        rq.vkCmdBuildAccelerationStructuresKHR(dev_->cmd(), 1, &bi, &ranges);
        after_build(*dev_);
        dev_->fn().vkCmdResetQueryPool(dev_->cmd(), sizes_query, 0, 1);
        rq.vkCmdWriteAccelerationStructuresPropertiesKHR(
            dev_->cmd(), 1, &a.handle, VK_QUERY_TYPE_ACCELERATION_STRUCTURE_COMPACTED_SIZE_KHR,
            sizes_query, 0);
        dev_->submit_and_wait();
        VkDeviceSize compact = 0;
        VK_CHECK(dev_->fn().vkGetQueryPoolResults, device, sizes_query, 0, 1, sizeof(compact),
                 &compact, sizeof(compact), VK_QUERY_RESULT_64_BIT | VK_QUERY_RESULT_WAIT_BIT);
        dev_->fn().vkDestroyQueryPool(device, sizes_query, nullptr);
        sizes_query = VK_NULL_HANDLE;
        dev_->free_buffer(scratch);
        // Compacted into a structure of that size where it is smaller.
        if (compact > 0 && compact < sizes.accelerationStructureSize) {
            Accel c;
            c.buffer = dev_->create_buffer(
                compact, VK_BUFFER_USAGE_ACCELERATION_STRUCTURE_STORAGE_BIT_KHR | kAddress, 0,
                VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT);
            ci.buffer = c.buffer.buffer;
            ci.size = compact;
            VK_CHECK(rq.vkCreateAccelerationStructureKHR, device, &ci, nullptr, &c.handle);
            VkCopyAccelerationStructureInfoKHR copy{};
            copy.sType = VK_STRUCTURE_TYPE_COPY_ACCELERATION_STRUCTURE_INFO_KHR;
            copy.src = a.handle;
            copy.dst = c.handle;
            copy.mode = VK_COPY_ACCELERATION_STRUCTURE_MODE_COMPACT_KHR;
            dev_->begin_commands();
            rq.vkCmdCopyAccelerationStructureKHR(dev_->cmd(), &copy);
            after_build(*dev_);
            dev_->submit_and_wait();
            destroy(a);
            a = c;
            stats_.compacted = true;
        }
    } catch (...) {
        if (sizes_query) dev_->fn().vkDestroyQueryPool(device, sizes_query, nullptr);
        dev_->free_buffer(scratch);
        destroy(a);
        throw;
    }
    VkAccelerationStructureDeviceAddressInfoKHR ai{};
    ai.sType = VK_STRUCTURE_TYPE_ACCELERATION_STRUCTURE_DEVICE_ADDRESS_INFO_KHR;
    ai.accelerationStructure = a.handle;
    a.address = rq.vkGetAccelerationStructureDeviceAddressKHR(device, &ai);
    stats_.bytes += a.buffer.size;
    return a;
}

void SceneAccel::build(Device& dev, const PhysicalDevice& pd,
                       const std::vector<gpu::GpuTriangle>& tris,
                       const std::vector<gpu::GpuSphere>& spheres, const std::vector<bool>& cut_out,
                       const std::string& fault) {
    release();
    // Planted faults (tests): a triangle left out (NaN corners make it inactive), boxes
    // that miss the spheres' rims, boxes moved off their spheres' centres (+z).
    uint64_t drop = UINT64_MAX;
    if (fault.rfind("drop:", 0) == 0) drop = std::stoull(fault.substr(5));
    const float box_scale = fault == "shrink" ? 0.5f : 1.0f + 1e-5f;
    const float box_shift = fault == "shift" ? 1.5f : 0.0f;  // in radii
    if (!fault.empty() && drop == UINT64_MAX && fault != "shrink" && fault != "shift")
        throw Error("vulkan: unknown acceleration-structure fault '" + fault + "'");
    if (!dev.accel()) throw Error("vulkan: " + pd.info.name + " has no acceleration structures");
    dev_ = &dev;
    pd_ = &pd;
    const auto t0 = std::chrono::steady_clock::now();
    const uint64_t max_primitives = pd.accel_props.maxPrimitiveCount;
    if (tris.size() > max_primitives || spheres.size() > max_primitives) {
        throw Error("vulkan: " + std::to_string(std::max(tris.size(), spheres.size())) +
                    " primitives exceed " + pd.info.name + "'s maxPrimitiveCount (" +
                    std::to_string(max_primitives) + ") for the driver's tracing");
    }
    std::vector<VkAccelerationStructureInstanceKHR> instances;
    // An instance of each bottom-level structure, naming its hit group in the ray-tracing
    // pipeline's binding table (ray queries ignore it) and, as its custom index, its first
    // primitive's index (traverse_driver.h adds the primitive's index within it).
    auto instance_of = [&](const Accel& a, uint32_t hit_group, uint32_t first) {
        VkAccelerationStructureInstanceKHR in{};
        in.transform.matrix[0][0] = in.transform.matrix[1][1] = in.transform.matrix[2][2] = 1.0f;
        in.instanceCustomIndex = first;
        in.mask = 0xff;
        in.instanceShaderBindingTableRecordOffset = hit_group;
        in.flags = VK_GEOMETRY_INSTANCE_TRIANGLE_FACING_CULL_DISABLE_BIT_KHR;
        in.accelerationStructureReference = a.address;
        instances.push_back(in);
    };
    try {
        // Triangles: three positions each, no index buffer (vertex 3i + k is vertex k of
        // triangle i), released after the build; one structure per run of triangles that are
        // all opaque or all cut out where they may be (alpha masks), so that only the latter
        // call on the shader's cut-out test.
        if (!tris.empty()) {
            std::vector<float> positions;
            positions.reserve(tris.size() * 9);
            for (const gpu::GpuTriangle& t : tris)
                positions.insert(positions.end(),
                                 {t.v0x, t.v0y, t.v0z, t.v1x, t.v1y, t.v1z, t.v2x, t.v2y, t.v2z});
            if (drop < tris.size()) positions[9 * drop] = std::numeric_limits<float>::quiet_NaN();
            const std::vector<TriangleRun> runs = triangle_runs(cut_out, tris.size());
            Buffer input = dev.upload(positions.data(), positions.size() * 4, kBuildInput);
            stats_.transient_bytes += input.size;
            try {
                for (const TriangleRun& run : runs) {
                    VkAccelerationStructureGeometryKHR g{};
                    g.sType = VK_STRUCTURE_TYPE_ACCELERATION_STRUCTURE_GEOMETRY_KHR;
                    g.geometryType = VK_GEOMETRY_TYPE_TRIANGLES_KHR;
                    g.flags = run.cut_out ? VK_GEOMETRY_NO_DUPLICATE_ANY_HIT_INVOCATION_BIT_KHR
                                          : VK_GEOMETRY_OPAQUE_BIT_KHR;
                    VkAccelerationStructureGeometryTrianglesDataKHR& td = g.geometry.triangles;
                    td.sType = VK_STRUCTURE_TYPE_ACCELERATION_STRUCTURE_GEOMETRY_TRIANGLES_DATA_KHR;
                    td.vertexFormat = VK_FORMAT_R32G32B32_SFLOAT;
                    td.vertexData.deviceAddress = address_of(input) + uint64_t(run.first) * 36;
                    td.vertexStride = 12;
                    td.maxVertex = run.count * 3 - 1;
                    td.indexType = VK_INDEX_TYPE_NONE_KHR;
                    triangle_runs_.push_back(
                        build_one(g, run.count, VK_ACCELERATION_STRUCTURE_TYPE_BOTTOM_LEVEL_KHR));
                    instance_of(triangle_runs_.back(), kTriangleHitGroup, run.first);
                }
            } catch (...) {
                dev.free_buffer(input);
                throw;
            }
            dev.free_buffer(input);
        }
        // Spheres: a box each, a hair larger than the sphere (the shader's test decides).
        if (!spheres.empty()) {
            std::vector<VkAabbPositionsKHR> boxes;
            for (const gpu::GpuSphere& s : spheres) {
                const float r = s.radius * box_scale, z = s.cz + s.radius * box_shift;
                boxes.push_back({s.cx - r, s.cy - r, z - r, s.cx + r, s.cy + r, z + r});
            }
            Buffer input = dev.upload(boxes.data(), boxes.size() * sizeof(boxes[0]), kBuildInput);
            stats_.transient_bytes += input.size;
            VkAccelerationStructureGeometryKHR g{};
            g.sType = VK_STRUCTURE_TYPE_ACCELERATION_STRUCTURE_GEOMETRY_KHR;
            g.geometryType = VK_GEOMETRY_TYPE_AABBS_KHR;
            g.flags = VK_GEOMETRY_OPAQUE_BIT_KHR;
            g.geometry.aabbs.sType =
                VK_STRUCTURE_TYPE_ACCELERATION_STRUCTURE_GEOMETRY_AABBS_DATA_KHR;
            g.geometry.aabbs.data.deviceAddress = address_of(input);
            g.geometry.aabbs.stride = sizeof(VkAabbPositionsKHR);
            try {
                spheres_ = build_one(g, uint32_t(spheres.size()),
                                     VK_ACCELERATION_STRUCTURE_TYPE_BOTTOM_LEVEL_KHR);
            } catch (...) {
                dev.free_buffer(input);
                throw;
            }
            dev.free_buffer(input);
            instance_of(spheres_, kSphereHitGroup, 0);
        }
        // The top level: an instance of each, untransformed (none in an empty scene, whose
        // input buffer still holds one).
        const uint32_t count = uint32_t(instances.size());
        instances.resize(std::max<size_t>(1, instances.size()));
        Buffer input =
            dev.upload(instances.data(), instances.size() * sizeof(instances[0]), kBuildInput);
        stats_.transient_bytes += input.size;
        VkAccelerationStructureGeometryKHR g{};
        g.sType = VK_STRUCTURE_TYPE_ACCELERATION_STRUCTURE_GEOMETRY_KHR;
        g.geometryType = VK_GEOMETRY_TYPE_INSTANCES_KHR;
        g.geometry.instances.sType =
            VK_STRUCTURE_TYPE_ACCELERATION_STRUCTURE_GEOMETRY_INSTANCES_DATA_KHR;
        g.geometry.instances.data.deviceAddress = address_of(input);
        try {
            top_ = build_one(g, count, VK_ACCELERATION_STRUCTURE_TYPE_TOP_LEVEL_KHR);
        } catch (...) {
            dev.free_buffer(input);
            throw;
        }
        dev.free_buffer(input);
    } catch (...) {
        release();
        throw;
    }
    stats_.build_seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

std::string SceneAccel::describe() const {
    char buf[192];
    std::snprintf(buf, sizeof buf,
                  "acceleration structures: %d bottom-level, %s%s, built in %.2f ms",
                  int(triangle_runs_.size()) + int(spheres_.handle != VK_NULL_HANDLE),
                  human_bytes(stats_.bytes).c_str(), stats_.compacted ? " (compacted)" : "",
                  stats_.build_seconds * 1e3);
    return buf;
}

}  // namespace mcpt::vk
