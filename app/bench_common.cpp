#include "app/bench_common.h"

#include <algorithm>
#include <cstdio>

#include "app/commands.h"
#include "common/accel/cpu_trace.h"
#include "common/error.h"
#include "common/render/gpu_scene.h"

namespace mcpt {

std::vector<OpenBackend> open_backends(const std::vector<std::string>& specs_in,
                                       const BackendOptions& options) {
    std::vector<std::string> specs = specs_in;
    if (specs.empty()) {
        for (const DeviceInfo& d : list_devices())
            specs.push_back(d.backend + ":" + std::to_string(d.index));
    }
    std::vector<OpenBackend> out;
    for (const std::string& s : specs) {
        try {
            out.push_back({s, open_device(s, options)});
        } catch (const std::exception& e) {
            std::printf("note: backend %s skipped: %s\n", s.c_str(), e.what());
            std::fflush(stdout);
        }
    }
    if (out.empty()) throw Error("no backend to benchmark");
    return out;
}

FrameTiming time_frames(Backend& backend, const GpuScene& g, const Camera& camera, RenderOptions ro,
                        int frames) {
    backend.load(g, ro.width, ro.height, ro.group_spp > 0);
    // Warm-up.
    const uint64_t spp = ro.spp;
    ro.spp = 1, ro.seed = 99;
    render_loaded(backend, g, camera, ro);
    // Timed frames: the median.
    ro.spp = spp;
    std::vector<std::pair<double, double>> t;  // seconds, rays
    for (int f = 0; f < frames; ++f) {
        ro.seed = uint32_t(f);
        const RenderResult r = render_loaded(backend, g, camera, ro);
        t.push_back({r.seconds, r.rays});
    }
    std::sort(t.begin(), t.end());
    const auto [sec, rays] = t[t.size() / 2];
    FrameTiming ft;
    ft.ms_per_frame = 1e3 * sec;
    ft.msamples = double(ro.width) * ro.height * double(spp) / sec * 1e-6;
    ft.mrays = rays / sec * 1e-6;
    return ft;
}

// Camera rays through a grid and a few hundred full paths, fewer when a ray is expensive.
Counts count_work(const GpuScene& g, const Scene& scene, const RenderOptions& ro,
                  const std::string& tree_kind) {
    gpu::GpuParams p = g.params;
    set_camera(p, scene.camera, ro.width, ro.height);
    p.max_depth = ro.max_depth, p.rr_depth = ro.rr_depth, p.seed = 12345;
    const double n_tris = double(std::max<size_t>(1, g.triangles.size()));
    const double per_ray = tree_kind == "none" ? n_tris : tree_kind == "median" ? n_tris / 4 : 64;
    const int side = std::clamp(int(std::sqrt(2e8 / per_ray)), 8, 64);
    const int paths = std::clamp(side * side / 16, 16, 256);
    Counts c;
    for (int y = 0; y < side; ++y) {
        for (int x = 0; x < side; ++x) {
            const float fx = (x + 0.5f) / side * 2 - 1, fy = 1 - (y + 0.5f) / side * 2;
            c.camera.add(cpu_trace(g, cpu_camera_ray(g, p, fx, fy), false));
        }
    }
    const uint32_t npix = uint32_t(ro.width) * uint32_t(ro.height);
    for (int i = 0; i < paths; ++i) {
        // Pixels spread over the image by a multiplicative hash.
        const uint32_t pixel = uint32_t((uint64_t(i) * 2654435761u) % npix);
        c.paths.add(cpu_path_work(g, p, pixel, uint32_t(i)));
    }
    c.rays_per_path = c.paths.rays / paths;
    return c;
}

std::string fmt(const char* format, double v) {
    char buf[64];
    std::snprintf(buf, sizeof buf, format, v);
    return buf;
}

}  // namespace mcpt
