#include "common/render/device_registry.h"

#include <algorithm>
#include <cctype>
#include <cstdint>
#include <cstdlib>

#include "common/accel/kdtree.h"
#include "common/error.h"
#if MCPT_WITH_OPENCL
#include "opencl/cl_backend.h"
#endif
#if MCPT_WITH_VULKAN
#include "vulkan/vk_backend.h"
#endif

namespace mcpt {

namespace {
std::string lower(std::string s) {
    std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return std::tolower(c); });
    return s;
}
std::string api_list() {
    std::string out;
    for (const std::string& a : device_apis()) out += (out.empty() ? "" : ", ") + a;
    return out;
}
}  // namespace

std::vector<std::string> device_apis() {
    std::vector<std::string> apis;
#if MCPT_WITH_OPENCL
    apis.push_back("opencl");
#endif
#if MCPT_WITH_VULKAN
    apis.push_back("vulkan");
#endif
    return apis;
}

DeviceSpec parse_device_spec(const std::string& full) {
    // Options after the first comma.
    const size_t comma = full.find(',');
    const std::string spec = full.substr(0, comma);
    DeviceSpec s;
    for (size_t at = comma; at != std::string::npos;) {
        const size_t next = full.find(',', at + 1);
        const std::string opt =
            full.substr(at + 1, next == std::string::npos ? next : next - at - 1);
        at = next;
        if (opt.rfind("tree=", 0) == 0) {
            s.tree = opt.substr(5);
            parse_tree_kind(s.tree);  // names the valid kinds if it is none of them
            continue;
        }
        if (opt.rfind("limits=", 0) != 0) {
            throw Error("unknown device option '" + opt + "' in '" + full +
                        "' (valid: limits=device, limits=phone, tree=<kind>)");
        }
        s.limits = opt.substr(7);
        if (s.limits != "device" && s.limits != "phone") {
            throw Error("unknown limits profile '" + s.limits + "' (valid: device, phone)");
        }
    }
    const size_t colon = spec.find(':');
    s.api = spec.substr(0, colon);
    s.device = colon == std::string::npos ? "" : spec.substr(colon + 1);
    const std::vector<std::string> apis = device_apis();
    if (std::find(apis.begin(), apis.end(), s.api) == apis.end()) {
        throw Error("unknown backend '" + s.api + "' (available in this build: " + api_list() +
                    ")");
    }
    return s;
}

std::vector<DeviceInfo> list_devices(const std::string& api) {
    std::vector<DeviceInfo> out;
#if MCPT_WITH_OPENCL
    if (api.empty() || api == "opencl") {
        for (DeviceInfo& d : list_opencl_devices()) out.push_back(std::move(d));
    }
#endif
#if MCPT_WITH_VULKAN
    if (api.empty() || api == "vulkan") {
        for (DeviceInfo& d : list_vulkan_devices()) out.push_back(std::move(d));
    }
#endif
    return out;
}

size_t select_device(const std::vector<DeviceInfo>& devices, const std::string& sel,
                     const std::string& api) {
    const std::string name = api == "opencl" ? "OpenCL" : api == "vulkan" ? "Vulkan" : api;
    if (devices.empty()) throw Error("no " + name + " device found");
    if (sel.empty()) {
        // Best: the first GPU, else the first device.
        for (size_t i = 0; i < devices.size(); ++i)
            if (devices[i].type == "gpu") return i;
        return 0;
    }
    if (std::all_of(sel.begin(), sel.end(), [](unsigned char c) { return std::isdigit(c); })) {
        const size_t i = sel.size() > 9 ? devices.size() : std::stoul(sel);
        if (i >= devices.size()) {
            throw Error(name + " device index " + sel + " out of range (" +
                        std::to_string(devices.size()) + " devices; see 'mcpt devices')");
        }
        return i;
    }
    for (size_t i = 0; i < devices.size(); ++i) {
        if (lower(devices[i].name).find(lower(sel)) != std::string::npos ||
            lower(devices[i].platform).find(lower(sel)) != std::string::npos)
            return i;
    }
    throw Error("no " + name + " device matches '" + sel + "' (see 'mcpt devices')");
}

std::unique_ptr<Backend> open_device(const std::string& spec, BackendOptions options) {
    if (spec.empty()) {
        // Any API: the first GPU, else the first device.
        const std::vector<DeviceInfo> all = list_devices();
        if (all.empty()) throw Error("no OpenCL or Vulkan device found (see 'mcpt devices')");
        const DeviceInfo* best = &all.front();
        for (const DeviceInfo& d : all) {
            if (d.type == "gpu") {
                best = &d;
                break;
            }
        }
        options.device = std::to_string(best->index);
        return open_device(best->backend, options);
    }
    const DeviceSpec s = parse_device_spec(spec);
    if (!s.device.empty()) options.device = s.device;
    if (options.lose_device_after == 0) {
        if (const char* e = std::getenv("MCPT_LOSE_DEVICE_AFTER")) {
            char* end = nullptr;
            const unsigned long n = std::strtoul(e, &end, 10);
            if (*e == '\0' || *end != '\0' || n > UINT32_MAX)
                throw Error(std::string("MCPT_LOSE_DEVICE_AFTER must be a dispatch count, not '") +
                            e + "'");
            options.lose_device_after = uint32_t(n);
        }
    }
    if (!s.limits.empty()) options.limits = s.limits;
#if MCPT_WITH_VULKAN
    if (s.api == "vulkan") return make_vulkan_backend(options);
#endif
#if MCPT_WITH_OPENCL
    if (s.api == "opencl") return make_opencl_backend(options);
#endif
    throw Error("backend '" + s.api + "' not built");
}

std::vector<std::string> device_specs(const std::string& backend,
                                      const std::vector<std::string>& devices) {
    if (devices.empty()) return {backend};
    std::vector<std::string> specs;
    for (const std::string& d : devices) {
        const bool has_api = d.rfind("opencl", 0) == 0 || d.rfind("vulkan", 0) == 0;
        specs.push_back(has_api ? d : backend + ":" + d);
    }
    return specs;
}

std::vector<std::string> device_list(const std::string& side) {
    std::vector<std::string> devices, options;
    std::string api;
    for (size_t at = 0; at <= side.size();) {
        const size_t comma = std::min(side.find(',', at), side.size());
        const std::string item = side.substr(at, comma - at);
        at = comma + 1;
        if (item.find('=') != std::string::npos) {
            options.push_back(item);
            continue;
        }
        if (item.empty()) throw Error("an empty device in '" + side + "'");
        const size_t colon = item.find(':');
        const bool has_api = item.rfind("opencl", 0) == 0 || item.rfind("vulkan", 0) == 0;
        if (has_api) api = item.substr(0, colon);
        if (!has_api && api.empty())
            throw Error("'" + item + "' in '" + side + "' names no API (opencl or vulkan)");
        devices.push_back(has_api ? item : api + ":" + item);
    }
    if (devices.empty()) throw Error("no device in '" + side + "'");
    for (std::string& d : devices)
        for (const std::string& o : options) d += "," + o;
    return devices;
}

std::string device_source_key() {
#if MCPT_WITH_OPENCL
    return opencl_kernel_source();
#else
    return "";
#endif
}

}  // namespace mcpt
