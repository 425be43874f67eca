#include "vulkan/vk_context.h"

#include <dlfcn.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <iterator>
#include <mutex>
#include <sstream>

#include "common/env_integer.h"
#include "common/error.h"
#include "vulkan/vk_limits_profile.h"

namespace mcpt::vk {

namespace {

// The loader's entry point, opened once; null if there is no loader.
PFN_vkGetInstanceProcAddr loader_entry() {
    static const PFN_vkGetInstanceProcAddr entry = []() -> PFN_vkGetInstanceProcAddr {
#if defined(__APPLE__)
        const char* names[] = {"libvulkan.1.dylib", "libMoltenVK.dylib"};
#else
        const char* names[] = {"libvulkan.so.1", "libvulkan.so"};
#endif
        for (const char* name : names) {
            if (void* lib = dlopen(name, RTLD_NOW | RTLD_LOCAL)) {
                return reinterpret_cast<PFN_vkGetInstanceProcAddr>(
                    dlsym(lib, "vkGetInstanceProcAddr"));
            }
        }
        return nullptr;
    }();
    return entry;
}

template <class Fn>
Fn global_fn(const char* name) {
    return reinterpret_cast<Fn>(loader_entry()(VK_NULL_HANDLE, name));
}

bool has_layer(const char* name) {
    auto enumerate =
        global_fn<PFN_vkEnumerateInstanceLayerProperties>("vkEnumerateInstanceLayerProperties");
    uint32_t n = 0;
    if (!enumerate || enumerate(&n, nullptr) != VK_SUCCESS) return false;
    std::vector<VkLayerProperties> layers(n);
    if (enumerate(&n, layers.data()) < 0) return false;
    for (uint32_t i = 0; i < n; ++i)
        if (std::strcmp(layers[i].layerName, name) == 0) return true;
    return false;
}

bool has_instance_extension(const char* layer, const char* name) {
    auto enumerate = global_fn<PFN_vkEnumerateInstanceExtensionProperties>(
        "vkEnumerateInstanceExtensionProperties");
    uint32_t n = 0;
    if (!enumerate || enumerate(layer, &n, nullptr) != VK_SUCCESS) return false;
    std::vector<VkExtensionProperties> exts(n);
    if (enumerate(layer, &n, exts.data()) < 0) return false;
    for (uint32_t i = 0; i < n; ++i)
        if (std::strcmp(exts[i].extensionName, name) == 0) return true;
    return false;
}

const char* kValidationLayer = "VK_LAYER_KHRONOS_validation";

std::string number(double v) {
    std::ostringstream o;
    o << v;
    return o.str();
}

}  // namespace

const char* result_name(VkResult r) {
    switch (r) {
#define MCPT_VK_RESULT(x) \
    case x:               \
        return #x;
        MCPT_VK_RESULT(VK_SUCCESS)
        MCPT_VK_RESULT(VK_NOT_READY)
        MCPT_VK_RESULT(VK_TIMEOUT)
        MCPT_VK_RESULT(VK_EVENT_SET)
        MCPT_VK_RESULT(VK_EVENT_RESET)
        MCPT_VK_RESULT(VK_INCOMPLETE)
        MCPT_VK_RESULT(VK_ERROR_OUT_OF_HOST_MEMORY)
        MCPT_VK_RESULT(VK_ERROR_OUT_OF_DEVICE_MEMORY)
        MCPT_VK_RESULT(VK_ERROR_INITIALIZATION_FAILED)
        MCPT_VK_RESULT(VK_ERROR_DEVICE_LOST)
        MCPT_VK_RESULT(VK_ERROR_MEMORY_MAP_FAILED)
        MCPT_VK_RESULT(VK_ERROR_LAYER_NOT_PRESENT)
        MCPT_VK_RESULT(VK_ERROR_EXTENSION_NOT_PRESENT)
        MCPT_VK_RESULT(VK_ERROR_FEATURE_NOT_PRESENT)
        MCPT_VK_RESULT(VK_ERROR_INCOMPATIBLE_DRIVER)
        MCPT_VK_RESULT(VK_ERROR_TOO_MANY_OBJECTS)
        MCPT_VK_RESULT(VK_ERROR_FORMAT_NOT_SUPPORTED)
        MCPT_VK_RESULT(VK_ERROR_FRAGMENTED_POOL)
        MCPT_VK_RESULT(VK_ERROR_UNKNOWN)
        MCPT_VK_RESULT(VK_ERROR_OUT_OF_POOL_MEMORY)
        MCPT_VK_RESULT(VK_ERROR_INVALID_EXTERNAL_HANDLE)
        MCPT_VK_RESULT(VK_ERROR_FRAGMENTATION)
        MCPT_VK_RESULT(VK_ERROR_INVALID_OPAQUE_CAPTURE_ADDRESS)
        MCPT_VK_RESULT(VK_PIPELINE_COMPILE_REQUIRED)
        MCPT_VK_RESULT(VK_ERROR_VALIDATION_FAILED_EXT)
#undef MCPT_VK_RESULT
        default:
            return "unknown VkResult";
    }
}

void check(VkResult r, const char* call) {
    if (r == VK_SUCCESS || r == VK_INCOMPLETE) return;
    const std::string what =
        std::string(call) + " failed: " + result_name(r) + " (" + std::to_string(int(r)) + ")";
    if (r == VK_ERROR_DEVICE_LOST) {
        throw DeviceLost(what +
                         ": the device was lost (a driver reset, or a watchdog ended a "
                         "submission that ran too long)");
    }
    throw Error(what);
}

const char* call_name(const char* expr) {
    const char* dot = std::strrchr(expr, '.');
    const char* arrow = std::strrchr(expr, '>');
    const char* last = std::max(dot ? dot : expr - 1, arrow ? arrow : expr - 1);
    return last + 1;
}

std::string lower(std::string s) {
    std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return std::tolower(c); });
    return s;
}

std::string version_string(uint32_t v) {
    return std::to_string(VK_API_VERSION_MAJOR(v)) + "." + std::to_string(VK_API_VERSION_MINOR(v)) +
           "." + std::to_string(VK_API_VERSION_PATCH(v));
}

bool validation_requested() {
    const char* e = std::getenv("MCPT_VULKAN_VALIDATION");
    return e && std::strcmp(e, "1") == 0;
}

MemoryLimits memory_limits(const PhysicalDevice& d) {
    // Tests may lower the range through the environment (read now, not when listed).
    MemoryLimits m;
    const uint64_t range = d.props.limits.maxStorageBufferRange;
    m.max_buffer_bytes = env_limit("MCPT_VULKAN_MAX_BUFFER_BYTES", range);
    m.max_buffer_name = "maxStorageBufferRange";
    if (m.max_buffer_bytes < range)
        m.max_buffer_note = " (lowered by MCPT_VULKAN_MAX_BUFFER_BYTES)";
    m.max_allocation_bytes = d.max_allocation;
    m.max_allocation_name = "maxMemoryAllocationSize";
    for (uint32_t t = 0; t < d.memory.memoryTypeCount; ++t) {
        if (d.memory.memoryTypes[t].propertyFlags & VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT) {
            m.device_memory_bytes = d.memory.memoryHeaps[d.memory.memoryTypes[t].heapIndex].size;
            break;
        }
    }
    return m;
}

uint64_t env_limit(const char* name, uint64_t fallback) {
    const char* e = std::getenv(name);
    if (!e || !*e) return fallback;
    char* end = nullptr;
    const unsigned long long v = std::strtoull(e, &end, 10);
    if (*end != '\0' || v == 0) throw Error(std::string(name) + " must be a positive integer");
    return std::min<uint64_t>(v, fallback);
}

Instance::Instance(bool validation) {
    // Loader, and a 1.1-capable one.
    if (!loader_entry()) throw Error(kNoDeviceMessage);
    auto enumerate_version =
        global_fn<PFN_vkEnumerateInstanceVersion>("vkEnumerateInstanceVersion");
    uint32_t loader_version = VK_API_VERSION_1_0;
    if (enumerate_version) enumerate_version(&loader_version);
    if (loader_version < VK_API_VERSION_1_1) {
        throw Error("the Vulkan loader supports only Vulkan " + version_string(loader_version) +
                    "; mcpt needs 1.1");
    }

    // Validation layer and debug-utils messenger, if asked for.
    std::vector<const char*> layers, extensions;
    VkDebugUtilsMessengerCreateInfoEXT messenger_info{};
    messenger_info.sType = VK_STRUCTURE_TYPE_DEBUG_UTILS_MESSENGER_CREATE_INFO_EXT;
    messenger_info.messageSeverity = VK_DEBUG_UTILS_MESSAGE_SEVERITY_WARNING_BIT_EXT |
                                     VK_DEBUG_UTILS_MESSAGE_SEVERITY_ERROR_BIT_EXT;
    // Not GENERAL: the loader reports there about other drivers (an arm64 ICD listed on a
    // multiarch system, layers added by the environment), nothing about mcpt's API use.
    messenger_info.messageType = VK_DEBUG_UTILS_MESSAGE_TYPE_VALIDATION_BIT_EXT |
                                 VK_DEBUG_UTILS_MESSAGE_TYPE_PERFORMANCE_BIT_EXT;
    messenger_info.pfnUserCallback = &Instance::on_message;
    messenger_info.pUserData = this;
    if (validation) {
        if (!has_layer(kValidationLayer)) {
            throw Error(
                "MCPT_VULKAN_VALIDATION=1 but VK_LAYER_KHRONOS_validation is not installed "
                "(install vulkan-validationlayers)");
        }
        if (!has_instance_extension(nullptr, VK_EXT_DEBUG_UTILS_EXTENSION_NAME) &&
            !has_instance_extension(kValidationLayer, VK_EXT_DEBUG_UTILS_EXTENSION_NAME)) {
            throw Error("MCPT_VULKAN_VALIDATION=1 but VK_EXT_debug_utils is not available");
        }
        layers.push_back(kValidationLayer);
        extensions.push_back(VK_EXT_DEBUG_UTILS_EXTENSION_NAME);
    }

    // Instance: API 1.2, the version ray queries take; a 1.1 device (Android-class drivers)
    // runs at its own 1.1, which is all the rest of mcpt needs.
    VkApplicationInfo app{};
    app.sType = VK_STRUCTURE_TYPE_APPLICATION_INFO;
    app.pApplicationName = "mcpt";
    app.applicationVersion = VK_MAKE_API_VERSION(0, 0, 1, 0);
    app.pEngineName = "mcpt";
    app.engineVersion = VK_MAKE_API_VERSION(0, 0, 1, 0);
    app.apiVersion = VK_API_VERSION_1_2;
    VkInstanceCreateInfo ci{};
    ci.sType = VK_STRUCTURE_TYPE_INSTANCE_CREATE_INFO;
    ci.pNext = validation ? &messenger_info : nullptr;  // also covers create/destroy
    ci.pApplicationInfo = &app;
    ci.enabledLayerCount = uint32_t(layers.size());
    ci.ppEnabledLayerNames = layers.data();
    ci.enabledExtensionCount = uint32_t(extensions.size());
    ci.ppEnabledExtensionNames = extensions.data();
    auto create = global_fn<PFN_vkCreateInstance>("vkCreateInstance");
    if (!create) throw Error(kNoDeviceMessage);
    const VkResult r = create(&ci, nullptr, &instance_);
    if (r == VK_ERROR_INCOMPATIBLE_DRIVER) throw Error(kNoDeviceMessage);
    check(r, "vkCreateInstance");

    // Instance-level functions.
    const PFN_vkGetInstanceProcAddr gipa = loader_entry();
#define MCPT_VK_LOAD(name)                                                                 \
    fn_.name = reinterpret_cast<PFN_##name>(gipa(instance_, #name));                       \
    if (!fn_.name) {                                                                       \
        fn_.vkDestroyInstance =                                                            \
            reinterpret_cast<PFN_vkDestroyInstance>(gipa(instance_, "vkDestroyInstance")); \
        if (fn_.vkDestroyInstance) fn_.vkDestroyInstance(instance_, nullptr);              \
        instance_ = VK_NULL_HANDLE;                                                        \
        throw Error("the Vulkan loader has no " #name);                                    \
    }
    MCPT_VK_INSTANCE_FUNCTIONS(MCPT_VK_LOAD)
#undef MCPT_VK_LOAD

    // Messenger for the rest of the instance's life.
    if (validation) {
        fn_.vkCreateDebugUtilsMessengerEXT = reinterpret_cast<PFN_vkCreateDebugUtilsMessengerEXT>(
            gipa(instance_, "vkCreateDebugUtilsMessengerEXT"));
        fn_.vkDestroyDebugUtilsMessengerEXT = reinterpret_cast<PFN_vkDestroyDebugUtilsMessengerEXT>(
            gipa(instance_, "vkDestroyDebugUtilsMessengerEXT"));
        VkResult mr = VK_ERROR_EXTENSION_NOT_PRESENT;
        if (fn_.vkCreateDebugUtilsMessengerEXT && fn_.vkDestroyDebugUtilsMessengerEXT) {
            mr = fn_.vkCreateDebugUtilsMessengerEXT(instance_, &messenger_info, nullptr,
                                                    &messenger_);
        }
        if (mr != VK_SUCCESS) {
            fn_.vkDestroyInstance(instance_, nullptr);
            instance_ = VK_NULL_HANDLE;
            check(mr, "vkCreateDebugUtilsMessengerEXT");
        }
    }
}

std::shared_ptr<Instance> shared_instance(bool validation) {
    // Never destroyed: the driver may be unloaded before static destructors run.
    static std::mutex mutex;
    static auto* kept = new std::shared_ptr<Instance>[2];
    std::lock_guard<std::mutex> lock(mutex);
    std::shared_ptr<Instance>& slot = kept[validation ? 1 : 0];
    if (!slot) slot = std::make_shared<Instance>(validation);
    return slot;
}

Instance::~Instance() {
    if (messenger_ != VK_NULL_HANDLE)
        fn_.vkDestroyDebugUtilsMessengerEXT(instance_, messenger_, nullptr);
    if (instance_ != VK_NULL_HANDLE) fn_.vkDestroyInstance(instance_, nullptr);
}

VKAPI_ATTR VkBool32 VKAPI_CALL Instance::on_message(
    VkDebugUtilsMessageSeverityFlagBitsEXT severity, VkDebugUtilsMessageTypeFlagsEXT,
    const VkDebugUtilsMessengerCallbackDataEXT* data, void* user) {
    // Count warnings and errors, print them.
    auto* self = static_cast<Instance*>(user);
    self->messages_.fetch_add(1);
    const char* level =
        (severity & VK_DEBUG_UTILS_MESSAGE_SEVERITY_ERROR_BIT_EXT) ? "error" : "warning";
    std::fprintf(stderr, "vulkan validation %s: %s\n", level,
                 data && data->pMessage ? data->pMessage : "(no message)");
    return VK_FALSE;
}

// Whether ray queries and the ray-tracing pipeline are usable on d (PhysicalDevice::ray_query
// and ray_pipeline, with the reason where not), from its extensions and features.
void Instance::probe_driver_tracing(PhysicalDevice& d,
                                    const std::vector<std::string>& extensions) const {
    if (d.props.apiVersion < VK_API_VERSION_1_2) {
        d.ray_query_note = d.ray_pipeline_note =
            "no (Vulkan " + version_string(d.props.apiVersion) + ", 1.2 needed)";
        return;
    }
    const auto has = [&](const char* e) {
        return std::find(extensions.begin(), extensions.end(), e) != extensions.end();
    };
    bool accel = true;
    for (const char* e : kAccelExtensions) accel = accel && has(e);
    VkPhysicalDeviceRayTracingPipelineFeaturesKHR rt{};
    rt.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_RAY_TRACING_PIPELINE_FEATURES_KHR;
    VkPhysicalDeviceRayQueryFeaturesKHR rq{};
    rq.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_RAY_QUERY_FEATURES_KHR;
    rq.pNext = has(kRayPipelineExtension) ? &rt : nullptr;
    VkPhysicalDeviceAccelerationStructureFeaturesKHR as{};
    as.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_ACCELERATION_STRUCTURE_FEATURES_KHR;
    as.pNext = has(kRayQueryExtension) ? static_cast<void*>(&rq) : rq.pNext;
    VkPhysicalDeviceVulkan12Features v12{};
    v12.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_2_FEATURES;
    v12.pNext = accel ? &as : nullptr;
    VkPhysicalDeviceFeatures2 f2{};
    f2.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_FEATURES_2;
    f2.pNext = &v12;
    fn_.vkGetPhysicalDeviceFeatures2(d.handle, &f2);
    const bool base = accel && as.accelerationStructure && v12.bufferDeviceAddress;
    const auto note = [&](bool extension, bool feature, const char* name) {
        if (!accel || !extension)
            return std::string("no (") + name + " or VK_KHR_acceleration_structure absent)";
        return std::string(base && feature ? "yes (" : "no (features not supported: ") + name + ")";
    };
    d.ray_query = base && has(kRayQueryExtension) && rq.rayQuery;
    d.ray_query_note = note(has(kRayQueryExtension), rq.rayQuery, kRayQueryExtension);
    d.ray_pipeline = base && has(kRayPipelineExtension) && rt.rayTracingPipeline;
    d.ray_pipeline_note =
        note(has(kRayPipelineExtension), rt.rayTracingPipeline, kRayPipelineExtension);
    if (!d.accel()) return;
    d.accel_props.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_ACCELERATION_STRUCTURE_PROPERTIES_KHR;
    d.rt_props.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_RAY_TRACING_PIPELINE_PROPERTIES_KHR;
    d.accel_props.pNext = d.ray_pipeline ? &d.rt_props : nullptr;
    VkPhysicalDeviceProperties2 p2{};
    p2.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_PROPERTIES_2;
    p2.pNext = &d.accel_props;
    fn_.vkGetPhysicalDeviceProperties2(d.handle, &p2);
    d.accel_props.pNext = nullptr;
    d.rt_props.pNext = nullptr;
}

std::vector<PhysicalDevice> Instance::devices(const std::string& profile_request) const {
    const std::string profile = resolve_limits_profile(profile_request);
    std::vector<PhysicalDevice> out;
    uint32_t n = 0;
    VK_CHECK(fn_.vkEnumeratePhysicalDevices, instance_, &n, nullptr);
    std::vector<VkPhysicalDevice> handles(n);
    VK_CHECK(fn_.vkEnumeratePhysicalDevices, instance_, &n, handles.data());
    handles.resize(n);
    for (VkPhysicalDevice h : handles) {
        PhysicalDevice d;
        d.handle = h;
        fn_.vkGetPhysicalDeviceProperties(h, &d.props);
        fn_.vkGetPhysicalDeviceMemoryProperties(h, &d.memory);
        const VkPhysicalDeviceLimits& l = d.props.limits;

        // Driver name (VK_KHR_driver_properties) and allocation limit (core 1.1).
        std::string driver, driver_info;
        if (d.props.apiVersion >= VK_API_VERSION_1_1) {
            uint32_t next = 0;
            VK_CHECK(fn_.vkEnumerateDeviceExtensionProperties, h, nullptr, &next, nullptr);
            std::vector<VkExtensionProperties> exts(next);
            VK_CHECK(fn_.vkEnumerateDeviceExtensionProperties, h, nullptr, &next, exts.data());
            std::vector<std::string> names;
            for (uint32_t i = 0; i < next; ++i) names.emplace_back(exts[i].extensionName);
            const bool has_driver_props =
                std::find(names.begin(), names.end(), VK_KHR_DRIVER_PROPERTIES_EXTENSION_NAME) !=
                names.end();
            probe_driver_tracing(d, names);
            if (std::find(names.begin(), names.end(), kPipelineStatisticsExtension) !=
                names.end()) {
                VkPhysicalDevicePipelineExecutablePropertiesFeaturesKHR pe{};
                pe.sType =
                    VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_PIPELINE_EXECUTABLE_PROPERTIES_FEATURES_KHR;
                VkPhysicalDeviceFeatures2 f2{};
                f2.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_FEATURES_2;
                f2.pNext = &pe;
                fn_.vkGetPhysicalDeviceFeatures2(h, &f2);
                d.pipeline_statistics = pe.pipelineExecutableInfo == VK_TRUE;
            }
            VkPhysicalDeviceDriverPropertiesKHR drv{};
            drv.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_DRIVER_PROPERTIES_KHR;
            VkPhysicalDeviceMaintenance3Properties m3{};
            m3.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_MAINTENANCE_3_PROPERTIES;
            m3.pNext = has_driver_props ? &drv : nullptr;
            VkPhysicalDeviceProperties2 p2{};
            p2.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_PROPERTIES_2;
            p2.pNext = &m3;
            fn_.vkGetPhysicalDeviceProperties2(h, &p2);
            d.max_allocation = m3.maxMemoryAllocationSize;
            if (has_driver_props) driver = drv.driverName, driver_info = drv.driverInfo;
        }

        apply_limits_profile(d, profile);

        // First queue family with compute.
        uint32_t nq = 0;
        fn_.vkGetPhysicalDeviceQueueFamilyProperties(h, &nq, nullptr);
        std::vector<VkQueueFamilyProperties> families(nq);
        fn_.vkGetPhysicalDeviceQueueFamilyProperties(h, &nq, families.data());
        for (uint32_t i = 0; i < nq && d.queue_family == UINT32_MAX; ++i) {
            if (families[i].queueFlags & VK_QUEUE_COMPUTE_BIT) {
                d.queue_family = i;
                d.timestamp_valid_bits = families[i].timestampValidBits;
            }
        }

        // What `mcpt devices` shows.
        DeviceInfo& i = d.info;
        i.backend = "vulkan";
        i.index = int(out.size());
        i.name = d.props.deviceName;
        i.platform = driver.empty() ? "Vulkan " + version_string(d.props.apiVersion) : driver;
        switch (d.props.deviceType) {
            case VK_PHYSICAL_DEVICE_TYPE_DISCRETE_GPU:
            case VK_PHYSICAL_DEVICE_TYPE_INTEGRATED_GPU:
            case VK_PHYSICAL_DEVICE_TYPE_VIRTUAL_GPU:
                i.type = "gpu";
                break;
            case VK_PHYSICAL_DEVICE_TYPE_CPU:
                i.type = "cpu";
                break;
            default:
                i.type = "other";
        }
        auto xyz = [](const uint32_t* v) {
            return std::to_string(v[0]) + " x " + std::to_string(v[1]) + " x " +
                   std::to_string(v[2]);
        };
        i.phone_limits = profile == "phone";
        i.limits = {
            {"limits profile",
             profile == "phone" ? "phone (Vulkan 1.1 required minimums)" : "device (as reported)"},
            {"apiVersion", version_string(d.props.apiVersion)},
            {"driver", driver.empty() ? "driverVersion " + std::to_string(d.props.driverVersion)
                                      : driver + " (" + driver_info + ")"},
            {"maxStorageBufferRange", human_bytes(l.maxStorageBufferRange)},
            {"maxMemoryAllocationSize",
             d.max_allocation ? human_bytes(d.max_allocation) : "unknown (Vulkan 1.0)"},
            {"maxComputeWorkGroupInvocations", std::to_string(l.maxComputeWorkGroupInvocations)},
            {"maxComputeWorkGroupSize", xyz(l.maxComputeWorkGroupSize)},
            {"maxComputeWorkGroupCount", xyz(l.maxComputeWorkGroupCount)},
            {"maxComputeSharedMemorySize", human_bytes(l.maxComputeSharedMemorySize)},
            {"maxPerStageDescriptorStorageBuffers",
             std::to_string(l.maxPerStageDescriptorStorageBuffers)},
            {"layout", layout_line(l)},
        };
        i.memory = memory_limits(d);
        for (uint32_t hi = 0; hi < d.memory.memoryHeapCount; ++hi) {
            const VkMemoryHeap& heap = d.memory.memoryHeaps[hi];
            i.limits.emplace_back(
                "memory heap " + std::to_string(hi),
                human_bytes(heap.size) +
                    ((heap.flags & VK_MEMORY_HEAP_DEVICE_LOCAL_BIT) ? ", device-local" : ""));
        }
        i.ray_queries = d.ray_query;
        i.ray_pipelines = d.ray_pipeline;
        i.limits.emplace_back("ray queries",
                              d.ray_query_note.empty() ? "no (Vulkan 1.0)" : d.ray_query_note);
        i.limits.emplace_back("ray-tracing pipeline", d.ray_pipeline_note.empty()
                                                          ? "no (Vulkan 1.0)"
                                                          : d.ray_pipeline_note);
        i.limits.emplace_back("timestamps", d.queue_family == UINT32_MAX ? "no compute queue"
                                            : d.timestamp_valid_bits == 0
                                                ? "none"
                                                : std::to_string(d.timestamp_valid_bits) +
                                                      " bits, " + number(l.timestampPeriod) +
                                                      " ns period");
        out.push_back(std::move(d));
    }
    return out;
}

bool pipeline_statistics_wanted() {
    return env_integer("MCPT_VULKAN_STATISTICS", 0, 1).value_or(0) == 1;
}

}  // namespace mcpt::vk
