#include "test_util.h"

#include "app/commands.h"

namespace mcpt::test {

std::unique_ptr<Backend> test_backend(const std::string& api, BackendOptions options) {
    if (api == "opencl") {
        if (options.device.empty()) options.device = test_opencl_device();
    } else if (const char* e = std::getenv("MCPT_TEST_VULKAN_DEVICE")) {
        if (options.device.empty()) options.device = e;
    }
    return open_backend(api, options);
}

}  // namespace mcpt::test
