// The device registry: every device of every API this build has, chosen by one spec,
// "api[:index|name]", and opened through the OpenCL or Vulkan host. Clients (the commands,
// the C API, tests) never call an API's host directly.
#pragma once
#include <memory>
#include <string>
#include <vector>

#include "common/render/backend.h"

namespace mcpt {

// "opencl", and "vulkan" where built with it.
std::vector<std::string> device_apis();

// Every device of `api` ("" = every API, in device_apis() order).
std::vector<DeviceInfo> list_devices(const std::string& api = "");

// "api", "api:device", each optionally followed by ",limits=phone|device" (the Vulkan limits
// profile, vk_limits_profile.h) and ",tree=<kind>" (the trace mode a side of an A/B renders
// with: kdtree.h's names), split; throws mcpt::Error for an unknown API or option.
struct DeviceSpec {
    std::string api, device, limits, tree;
};
DeviceSpec parse_device_spec(const std::string& spec);

// The position in `devices` (one API's list) that `selector` picks: "" = the first GPU, else
// the first device; digits = an index; else a case-insensitive substring of the device or
// platform name. Throws mcpt::Error naming the API when none matches.
size_t select_device(const std::vector<DeviceInfo>& devices, const std::string& selector,
                     const std::string& api);

// Opens the device of `spec` ("opencl", "vulkan:1", "opencl:pthread", "vulkan,limits=phone";
// "" = the first GPU of any API, else the first device); a device or limits profile given in
// `spec` overrides options.device or options.limits.
std::unique_ptr<Backend> open_device(const std::string& spec, BackendOptions options = {});

// The device specs of --backend and the --device values (an index, a name substring, or
// api:device); none: the backend's best device.
std::vector<std::string> device_specs(const std::string& backend,
                                      const std::vector<std::string>& devices);
// A side of compare or view on one device or several: "opencl:0,opencl:1,limits=phone" ->
// {"opencl:0,limits=phone", "opencl:1,limits=phone"}: options (name=value) apply to every
// device; a bare index or name takes the API before it ("vulkan:0,1").
std::vector<std::string> device_list(const std::string& side);

// What the device code is: the kernel source, a key of cached results that depend on it.
std::string device_source_key();

}  // namespace mcpt
