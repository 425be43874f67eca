// mcpt devices: every backend and device found, with the limits that matter.
#include <cstdio>

#include "app/commands.h"
#include "opencl/cl_backend.h"

namespace mcpt {

void add_devices_command(CLI::App& app) {
    CLI::App* sub = app.add_subcommand("devices", "List backends and devices with their limits");
    sub->callback([] {
        const std::vector<DeviceInfo> cl = list_opencl_devices();
        std::printf("opencl: %zu device(s)\n", cl.size());
        for (const DeviceInfo& d : cl) {
            std::printf("  [%d] %s (%s, %s)\n", d.index, d.name.c_str(), d.platform.c_str(),
                        d.type.c_str());
            for (const auto& [k, v] : d.limits) std::printf("      %-22s %s\n", k.c_str(), v.c_str());
        }
    });
}

}  // namespace mcpt
