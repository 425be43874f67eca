// What the benchmark commands share: the backends to measure and frame timing.
#pragma once
#include <memory>
#include <string>
#include <vector>

#include "common/gpu/ray_types.h"
#include "common/render/backend.h"
#include "common/render/render_loop.h"
#include "common/scene/scene.h"

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

// Work per ray counted by the shared traversal on the CPU (untimed): camera rays, and the
// rays of full paths.
struct Counts {
    gpu::RayWork camera, paths;
    double rays_per_path = 0;
};

// Camera rays through a grid and a few hundred full paths, fewer when a ray is expensive
// (tree_kind: none, median or sah, for the estimate of that cost).
Counts count_work(const GpuScene& g, const Scene& scene, const RenderOptions& ro,
                  const std::string& tree_kind);

// printf-style formatting of one number.
std::string fmt(const char* format, double v);

}  // namespace mcpt
