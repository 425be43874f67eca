#include "vulkan/vk_device.h"

#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>

#include "common/error.h"

namespace mcpt::vk {

Device::Device(const Instance& instance, const PhysicalDevice& pd, std::string name)
    : memory_(pd.memory), name_(std::move(name)) {
    const InstanceFns& fi = instance.fn();
    // Device with one compute queue; no features, no extensions, unless the driver traces
    // (ray queries, the ray-tracing pipeline: each where the device has it) or the driver's
    // pipeline statistics are asked for.
    const float priority = 1.f;
    VkDeviceQueueCreateInfo qi{};
    qi.sType = VK_STRUCTURE_TYPE_DEVICE_QUEUE_CREATE_INFO;
    qi.queueFamilyIndex = pd.queue_family;
    qi.queueCount = 1;
    qi.pQueuePriorities = &priority;
    VkDeviceCreateInfo di{};
    di.sType = VK_STRUCTURE_TYPE_DEVICE_CREATE_INFO;
    di.queueCreateInfoCount = 1;
    di.pQueueCreateInfos = &qi;
    std::vector<const char*> extensions(std::begin(kAccelExtensions), std::end(kAccelExtensions));
    VkPhysicalDeviceRayTracingPipelineFeaturesKHR rt{};
    rt.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_RAY_TRACING_PIPELINE_FEATURES_KHR;
    rt.rayTracingPipeline = VK_TRUE;
    VkPhysicalDeviceRayQueryFeaturesKHR rq{};
    rq.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_RAY_QUERY_FEATURES_KHR;
    rq.rayQuery = VK_TRUE;
    VkPhysicalDeviceAccelerationStructureFeaturesKHR as{};
    as.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_ACCELERATION_STRUCTURE_FEATURES_KHR;
    as.accelerationStructure = VK_TRUE;
    VkPhysicalDeviceVulkan12Features v12{};
    v12.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_2_FEATURES;
    v12.bufferDeviceAddress = VK_TRUE;
    v12.pNext = &as;
    void** tail = &as.pNext;
    if (pd.ray_query) {
        extensions.push_back(kRayQueryExtension);
        *tail = &rq;
        tail = &rq.pNext;
    }
    if (pd.ray_pipeline) {
        extensions.push_back(kRayPipelineExtension);
        *tail = &rt;
    }
    if (!pd.accel()) extensions.clear();
    void* chain = pd.accel() ? &v12 : nullptr;
    // The driver's statistics of each pipeline, where asked for and the device has them.
    VkPhysicalDevicePipelineExecutablePropertiesFeaturesKHR pe{};
    pe.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_PIPELINE_EXECUTABLE_PROPERTIES_FEATURES_KHR;
    pe.pipelineExecutableInfo = VK_TRUE;
    if (pipeline_statistics_wanted() && pd.pipeline_statistics) {
        extensions.push_back(kPipelineStatisticsExtension);
        pe.pNext = chain;
        chain = &pe;
    }
    di.pNext = chain;
    di.enabledExtensionCount = uint32_t(extensions.size());
    di.ppEnabledExtensionNames = extensions.empty() ? nullptr : extensions.data();
    VK_CHECK(fi.vkCreateDevice, pd.handle, &di, nullptr, &device_);

    // Device-level functions, all or none.
    DeviceFns loaded;
    const char* missing = nullptr;
#define MCPT_VK_LOAD_INTO(fns, name)                                                 \
    fns.name = reinterpret_cast<PFN_##name>(fi.vkGetDeviceProcAddr(device_, #name)); \
    if (!fns.name && !missing) missing = #name;
#define MCPT_VK_LOAD(name) MCPT_VK_LOAD_INTO(loaded, name)
    MCPT_VK_DEVICE_FUNCTIONS(MCPT_VK_LOAD)
#undef MCPT_VK_LOAD
    if (missing) {
        if (loaded.vkDestroyDevice) loaded.vkDestroyDevice(device_, nullptr);
        throw Error("the Vulkan driver of " + name_ + " has no " + missing);
    }
    f_ = loaded;
#define MCPT_VK_LOAD(name) MCPT_VK_LOAD_INTO(accel_fns_, name)
    if (pd.accel()) {
        MCPT_VK_ACCEL_FUNCTIONS(MCPT_VK_LOAD)
    }
#undef MCPT_VK_LOAD
#define MCPT_VK_LOAD(name) MCPT_VK_LOAD_INTO(rt_fns_, name)
    if (pd.ray_pipeline) {
        MCPT_VK_RAY_PIPELINE_FUNCTIONS(MCPT_VK_LOAD)
    }
#undef MCPT_VK_LOAD
#undef MCPT_VK_LOAD_INTO
    if (missing) {
        f_.vkDestroyDevice(device_, nullptr);
        throw Error("the Vulkan driver of " + name_ + " has no " + missing);
    }
    accel_ = pd.accel();
    rt_ = pd.ray_pipeline;
    if (chain == &pe) {
        get_executables_ = reinterpret_cast<PFN_vkGetPipelineExecutablePropertiesKHR>(
            fi.vkGetDeviceProcAddr(device_, "vkGetPipelineExecutablePropertiesKHR"));
        get_statistics_ = reinterpret_cast<PFN_vkGetPipelineExecutableStatisticsKHR>(
            fi.vkGetDeviceProcAddr(device_, "vkGetPipelineExecutableStatisticsKHR"));
        statistics_ = get_executables_ && get_statistics_;
    }
    f_.vkGetDeviceQueue(device_, pd.queue_family, 0, &queue_);

    // Command pool, one reusable command buffer, a fence.
    try {
        VkCommandPoolCreateInfo pi{};
        pi.sType = VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO;
        pi.flags = VK_COMMAND_POOL_CREATE_TRANSIENT_BIT;
        pi.queueFamilyIndex = pd.queue_family;
        VK_CHECK(f_.vkCreateCommandPool, device_, &pi, nullptr, &pool_);
        VkCommandBufferAllocateInfo ai{};
        ai.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO;
        ai.commandPool = pool_;
        ai.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
        ai.commandBufferCount = 1;
        VK_CHECK(f_.vkAllocateCommandBuffers, device_, &ai, &cmd_);
        VkFenceCreateInfo fci{};
        fci.sType = VK_STRUCTURE_TYPE_FENCE_CREATE_INFO;
        VK_CHECK(f_.vkCreateFence, device_, &fci, nullptr, &fence_);
    } catch (...) {
        destroy();
        throw;
    }
}

std::string Device::pipeline_statistics(VkPipeline pipeline) const {
    if (!statistics_ || pipeline == VK_NULL_HANDLE) return "";
    VkPipelineInfoKHR pi{};
    pi.sType = VK_STRUCTURE_TYPE_PIPELINE_INFO_KHR;
    pi.pipeline = pipeline;
    uint32_t n = 0;
    if (get_executables_(device_, &pi, &n, nullptr) != VK_SUCCESS) return "";
    std::vector<VkPipelineExecutablePropertiesKHR> executables(n);
    for (auto& e : executables) e.sType = VK_STRUCTURE_TYPE_PIPELINE_EXECUTABLE_PROPERTIES_KHR;
    if (get_executables_(device_, &pi, &n, executables.data()) != VK_SUCCESS) return "";
    // Each executable's statistics, "name value" (a compute pipeline has one executable).
    std::string out;
    for (uint32_t i = 0; i < n; ++i) {
        VkPipelineExecutableInfoKHR ei{};
        ei.sType = VK_STRUCTURE_TYPE_PIPELINE_EXECUTABLE_INFO_KHR;
        ei.pipeline = pipeline;
        ei.executableIndex = i;
        uint32_t m = 0;
        if (get_statistics_(device_, &ei, &m, nullptr) != VK_SUCCESS) continue;
        std::vector<VkPipelineExecutableStatisticKHR> stats(m);
        for (auto& s : stats) s.sType = VK_STRUCTURE_TYPE_PIPELINE_EXECUTABLE_STATISTIC_KHR;
        if (get_statistics_(device_, &ei, &m, stats.data()) != VK_SUCCESS) continue;
        if (n > 1) out += std::string(out.empty() ? "" : "; ") + executables[i].name + ": ";
        for (uint32_t k = 0; k < m; ++k) {
            const VkPipelineExecutableStatisticKHR& s = stats[k];
            std::string value;
            switch (s.format) {
                case VK_PIPELINE_EXECUTABLE_STATISTIC_FORMAT_BOOL32_KHR:
                    value = s.value.b32 ? "yes" : "no";
                    break;
                case VK_PIPELINE_EXECUTABLE_STATISTIC_FORMAT_INT64_KHR:
                    value = std::to_string(s.value.i64);
                    break;
                case VK_PIPELINE_EXECUTABLE_STATISTIC_FORMAT_UINT64_KHR:
                    value = std::to_string(s.value.u64);
                    break;
                default:
                    value = std::to_string(s.value.f64);
            }
            out += std::string(k ? ", " : "") + s.name + " " + value;
        }
    }
    return out;
}

Device::~Device() {
    destroy();
}

void Device::destroy() {
    if (device_ == VK_NULL_HANDLE) return;
    f_.vkDeviceWaitIdle(device_);
    if (fence_) f_.vkDestroyFence(device_, fence_, nullptr);
    if (pool_) f_.vkDestroyCommandPool(device_, pool_, nullptr);
    f_.vkDestroyDevice(device_, nullptr);
    device_ = VK_NULL_HANDLE;
}

void Device::wait_idle() {
    VK_CHECK(f_.vkDeviceWaitIdle, device_);
}

Buffer Device::create_buffer(VkDeviceSize size, VkBufferUsageFlags usage,
                             VkMemoryPropertyFlags required, VkMemoryPropertyFlags preferred) {
    // Buffer, then memory of the first matching type, bound and (if host-visible) mapped.
    Buffer b;
    b.size = size;
    VkBufferCreateInfo bi{};
    bi.sType = VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO;
    bi.size = size;
    bi.usage = usage;
    bi.sharingMode = VK_SHARING_MODE_EXCLUSIVE;
    VK_CHECK(f_.vkCreateBuffer, device_, &bi, nullptr, &b.buffer);
    try {
        VkMemoryRequirements req;
        f_.vkGetBufferMemoryRequirements(device_, b.buffer, &req);
        uint32_t type = UINT32_MAX;
        for (const VkMemoryPropertyFlags want : {required | preferred, required}) {
            for (uint32_t t = 0; t < memory_.memoryTypeCount && type == UINT32_MAX; ++t) {
                if ((req.memoryTypeBits & (1u << t)) &&
                    (memory_.memoryTypes[t].propertyFlags & want) == want)
                    type = t;
            }
        }
        if (type == UINT32_MAX) throw Error("no Vulkan memory type for a buffer on " + name_);
        VkMemoryAllocateFlagsInfo flags{};
        flags.sType = VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_FLAGS_INFO;
        flags.flags = VK_MEMORY_ALLOCATE_DEVICE_ADDRESS_BIT;
        VkMemoryAllocateInfo mi{};
        mi.sType = VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO;
        if (usage & VK_BUFFER_USAGE_SHADER_DEVICE_ADDRESS_BIT) mi.pNext = &flags;
        mi.allocationSize = req.size;
        mi.memoryTypeIndex = type;
        VK_CHECK(f_.vkAllocateMemory, device_, &mi, nullptr, &b.memory);
        VK_CHECK(f_.vkBindBufferMemory, device_, b.buffer, b.memory, 0);
        if ((memory_.memoryTypes[type].propertyFlags & kHostMemory) == kHostMemory)
            VK_CHECK(f_.vkMapMemory, device_, b.memory, 0, VK_WHOLE_SIZE, 0, &b.mapped);
    } catch (...) {
        free_buffer(b);
        throw;
    }
    return b;
}

void Device::free_buffer(Buffer& b) {
    if (b.mapped) f_.vkUnmapMemory(device_, b.memory);
    if (b.buffer) f_.vkDestroyBuffer(device_, b.buffer, nullptr);
    if (b.memory) f_.vkFreeMemory(device_, b.memory, nullptr);
    b = Buffer{};
}

Buffer Device::upload(const void* data, size_t bytes, VkBufferUsageFlags more_usage) {
    Buffer b = create_buffer(
        bytes, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT | more_usage,
        0, VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT);
    if (b.mapped) {
        std::memcpy(b.mapped, data, bytes);
        return b;
    }
    // Not host-visible: copy through a staging buffer.
    Buffer staging = create_buffer(bytes, VK_BUFFER_USAGE_TRANSFER_SRC_BIT, kHostMemory, 0);
    try {
        std::memcpy(staging.mapped, data, bytes);
        begin_commands();
        const VkBufferCopy region{0, 0, bytes};
        f_.vkCmdCopyBuffer(cmd_, staging.buffer, b.buffer, 1, &region);
        barrier(
            VK_PIPELINE_STAGE_TRANSFER_BIT, VK_ACCESS_TRANSFER_WRITE_BIT,
            shader_stages() | (accel_ ? VK_PIPELINE_STAGE_ACCELERATION_STRUCTURE_BUILD_BIT_KHR : 0),
            VK_ACCESS_SHADER_READ_BIT);
        submit_and_wait();
    } catch (...) {
        free_buffer(staging);
        free_buffer(b);
        throw;
    }
    free_buffer(staging);
    return b;
}

void Device::begin_commands() {
    VK_CHECK(f_.vkResetCommandPool, device_, pool_, 0);
    VkCommandBufferBeginInfo bi{};
    bi.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO;
    bi.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
    VK_CHECK(f_.vkBeginCommandBuffer, cmd_, &bi);
}

void Device::submit_and_wait() {
    VK_CHECK(f_.vkEndCommandBuffer, cmd_);
    VkSubmitInfo si{};
    si.sType = VK_STRUCTURE_TYPE_SUBMIT_INFO;
    si.commandBufferCount = 1;
    si.pCommandBuffers = &cmd_;
    VK_CHECK(f_.vkResetFences, device_, 1, &fence_);
    VK_CHECK(f_.vkQueueSubmit, queue_, 1, &si, fence_);
    VK_CHECK(f_.vkWaitForFences, device_, 1, &fence_, VK_TRUE, UINT64_MAX);
}

void Device::barrier(VkPipelineStageFlags src_stage, VkAccessFlags src,
                     VkPipelineStageFlags dst_stage, VkAccessFlags dst) {
    VkMemoryBarrier mb{};
    mb.sType = VK_STRUCTURE_TYPE_MEMORY_BARRIER;
    mb.srcAccessMask = src;
    mb.dstAccessMask = dst;
    f_.vkCmdPipelineBarrier(cmd_, src_stage, dst_stage, 0, 1, &mb, 0, nullptr, 0, nullptr);
}

std::string pipeline_cache_path(const VkPhysicalDeviceProperties& props) {
    std::filesystem::path dir;
    if (const char* x = std::getenv("XDG_CACHE_HOME"); x && *x) {
        dir = std::filesystem::path(x) / "mcpt";
    } else if (const char* h = std::getenv("HOME"); h && *h) {
        dir = std::filesystem::path(h) / ".cache" / "mcpt";
    } else {
        return "";
    }
    char name[64];
    std::snprintf(name, sizeof(name), "vk_pipeline_cache_%04x_%04x.bin", props.vendorID,
                  props.deviceID);
    return (dir / name).string();
}

std::vector<char> read_pipeline_cache(const std::string& path,
                                      const VkPhysicalDeviceProperties& props) {
    // The file, if any.
    std::error_code ec;
    if (path.empty() || !std::filesystem::exists(path, ec)) return {};
    std::ifstream in(path, std::ios::binary);
    std::vector<char> data(std::istreambuf_iterator<char>(in), {});
    if (!in.is_open() || in.bad()) {
        std::fprintf(stderr, "mcpt: warning: cannot read the Vulkan pipeline cache %s\n",
                     path.c_str());
        return {};
    }
    // VkPipelineCacheHeaderVersionOne: length, version, vendor, device, cache UUID.
    constexpr size_t kHeader = 16 + VK_UUID_SIZE;
    if (data.size() < kHeader) return {};
    uint32_t h[4];
    std::memcpy(h, data.data(), sizeof(h));
    const bool valid = h[0] >= kHeader && h[0] <= data.size() &&
                       h[1] == VK_PIPELINE_CACHE_HEADER_VERSION_ONE && h[2] == props.vendorID &&
                       h[3] == props.deviceID &&
                       std::memcmp(data.data() + 16, props.pipelineCacheUUID, VK_UUID_SIZE) == 0;
    return valid ? data : std::vector<char>();
}

void write_pipeline_cache(const std::string& path, const std::vector<char>& data) {
    if (path.empty()) return;
    const std::string tmp = path + ".tmp" + std::to_string(getpid());
    std::error_code ec;
    std::filesystem::create_directories(std::filesystem::path(path).parent_path(), ec);
    {
        std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
        out.write(data.data(), std::streamsize(data.size()));
        if (!out) ec = std::make_error_code(std::errc::io_error);
    }
    if (!ec) std::filesystem::rename(tmp, path, ec);
    if (ec) {
        std::error_code ignored;
        std::filesystem::remove(tmp, ignored);
        std::fprintf(stderr, "mcpt: warning: cannot write the Vulkan pipeline cache %s: %s\n",
                     path.c_str(), ec.message().c_str());
    }
}

}  // namespace mcpt::vk
