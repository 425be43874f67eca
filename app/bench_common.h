// What the benchmark commands share: the backends to measure and frame timing.
#pragma once
#include <memory>
#include <string>
#include <vector>

#include "common/render/backend.h"
#include "common/render/render_loop.h"

namespace mcpt {

struct OpenBackend {
    std::string spec;
    std::unique_ptr<Backend> backend;
};

// Every OpenCL and Vulkan device, or the specs given (opencl|vulkan[:device]); a device
// that fails to open is noted and skipped. Throws if none is left.
std::vector<OpenBackend> open_backends(const std::vector<std::string>& specs,
                                       const BackendOptions& options = {});

struct FrameTiming {
    double ms_per_frame = 0, msamples = 0, mrays = 0;  // per second
};

// Loads the scene, renders a warm-up frame, then returns the median of `frames` timed
// frames of ro.spp samples per pixel.
FrameTiming time_frames(Backend& backend, const GpuScene& g, const Camera& camera, RenderOptions ro,
                        int frames);

// printf-style formatting of one number.
std::string fmt(const char* format, double v);

}  // namespace mcpt
