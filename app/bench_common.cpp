#include "app/bench_common.h"

#include <algorithm>
#include <cstdio>

#include "app/commands.h"
#include "common/error.h"

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
    backend.load(g, ro.width, ro.height);
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

std::string fmt(const char* format, double v) {
    char buf[64];
    std::snprintf(buf, sizeof buf, format, v);
    return buf;
}

}  // namespace mcpt
