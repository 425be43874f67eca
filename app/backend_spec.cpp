#include <memory>

#include "app/commands.h"
#include "common/error.h"
#include "opencl/cl_backend.h"
#if MCPT_WITH_VULKAN
#include "vulkan/vk_backend.h"
#endif

namespace mcpt {

std::unique_ptr<Backend> open_backend(const std::string& spec, BackendOptions options) {
    // "api" or "api:device".
    const size_t colon = spec.find(':');
    const std::string api = spec.substr(0, colon);
    if (colon != std::string::npos) options.device = spec.substr(colon + 1);
    if (api == "opencl") return make_opencl_backend(options);
#if MCPT_WITH_VULKAN
    if (api == "vulkan") return make_vulkan_backend(options);
    throw Error("unknown backend '" + api + "' (available: opencl, vulkan)");
#else
    throw Error("unknown backend '" + api + "' (available: opencl; built without Vulkan)");
#endif
}

}  // namespace mcpt
