// mcpt devices: every backend and device found, with the limits that matter.
#include <cstdio>

#include "app/commands.h"

namespace mcpt {

void run_devices() {
    const auto print = [](const char* backend, const std::vector<DeviceInfo>& devices) {
        std::printf("%s: %zu device(s)\n", backend, devices.size());
        for (const DeviceInfo& d : devices) {
            std::printf("  [%d] %s (%s, %s)\n", d.index, d.name.c_str(), d.platform.c_str(),
                        d.type.c_str());
            for (const auto& [k, v] : d.limits)
                std::printf("      %-30s %s\n", k.c_str(), v.c_str());
        }
    };
    for (const std::string& api : device_apis()) print(api.c_str(), list_devices(api));
}

}  // namespace mcpt
