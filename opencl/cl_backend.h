// OpenCL backend (the reference): device discovery, program build with the embedded kernel
// source, buffer upload, dispatch and read-back. Nothing else lives here.
#pragma once
#include <memory>
#include <vector>

#include "common/render/backend.h"

namespace mcpt {

// Every OpenCL device of every platform; an empty list if there is no ICD.
std::vector<DeviceInfo> list_opencl_devices();

// Opens the device chosen by options.device ("" = first GPU, else first device; an index
// into list_opencl_devices(); or a case-insensitive substring of the device or platform
// name). Throws mcpt::Error if none matches.
std::unique_ptr<Backend> make_opencl_backend(const BackendOptions& options);

// The OpenCL C source embedded at build time (shared includes inlined).
const char* opencl_kernel_source();

}  // namespace mcpt
