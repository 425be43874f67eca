#include "render_loop.h"

#include <algorithm>
#include <chrono>
#include <cmath>

#include "error.h"

namespace mcpt {

std::vector<float> RenderResult::mean_image() const {
    const size_t n = size_t(width) * size_t(height);
    std::vector<float> img(3 * n, 0.f);
    for (size_t i = 0; i < n; ++i) {
        const double count = double(spp) - nonfinite[i];
        for (int c = 0; c < 3; ++c) img[3 * i + c] = count > 0 ? float(sum[3 * i + c] / count) : 0.f;
    }
    return img;
}

std::vector<float> RenderResult::std_error_image() const {
    const size_t n = size_t(width) * size_t(height);
    std::vector<float> err(3 * n, 0.f);
    for (size_t i = 0; i < n; ++i) {
        const double count = double(spp) - nonfinite[i];
        if (count < 2) continue;
        for (int c = 0; c < 3; ++c) {
            const double mean = sum[3 * i + c] / count;
            const double var = std::max(0.0, (sum_sq[3 * i + c] / count - mean * mean)) *
                               count / (count - 1);
            err[3 * i + c] = float(std::sqrt(var / count));
        }
    }
    return err;
}

double RenderResult::mean_radiance() const {
    const std::vector<float> img = mean_image();
    double total = 0;
    for (float v : img) total += v;
    return img.empty() ? 0 : total / double(img.size());
}

RenderResult render(Backend& backend, const GpuScene& scene, const Camera& camera,
                    const RenderOptions& opt, const ProgressFn& progress) {
    if (opt.width <= 0 || opt.height <= 0 || opt.width > 16384 || opt.height > 16384) {
        throw Error("image size must be between 1x1 and 16384x16384");
    }
    backend.load(scene, opt.width, opt.height);
    return render_loaded(backend, scene, camera, opt, progress);
}

RenderResult render_loaded(Backend& backend, const GpuScene& scene, const Camera& camera,
                           const RenderOptions& opt, const ProgressFn& progress) {
    using clock = std::chrono::steady_clock;
    if (opt.spp == 0 && !(opt.seconds > 0)) throw Error("give a sample count or a time budget");
    const uint32_t npix = uint32_t(opt.width) * uint32_t(opt.height);

    gpu::GpuParams p = scene.params;
    set_camera(p, camera, opt.width, opt.height);
    p.max_depth = opt.max_depth;
    p.rr_depth = opt.rr_depth;
    p.seed = opt.seed;
    p.light_scale = opt.light_scale;

    RenderResult r;
    r.width = opt.width, r.height = opt.height;
    r.sum.assign(3 * size_t(npix), 0.0);
    r.sum_sq.assign(3 * size_t(npix), 0.0);
    r.nonfinite.assign(npix, 0.0);
    std::vector<float> device_sums;

    // Work per dispatch (pixel-samples), adapted to the measured rate.
    double work = std::min<double>(npix, 4096);
    uint32_t unflushed = 0;
    const auto start = clock::now();
    auto elapsed = [&] { return std::chrono::duration<double>(clock::now() - start).count(); };
    auto flush = [&] {
        backend.read_accum(device_sums);
        for (size_t i = 0; i < npix; ++i) {
            const float* a = &device_sums[8 * i];
            for (int c = 0; c < 3; ++c) {
                r.sum[3 * i + c] += a[c];
                r.sum_sq[3 * i + c] += a[4 + c];
            }
            r.nonfinite[i] += a[3];
            r.nonfinite_total += uint64_t(a[3]);
            r.rays += a[7];
        }
        unflushed = 0;
    };

    while (true) {
        // One pass: every pixel gets `spp` more samples, in tiles of at most `work` pixels.
        uint32_t spp = uint32_t(std::max(1.0, std::floor(work / npix)));
        spp = std::min({spp, opt.flush_spp - unflushed, backend.max_samples_per_dispatch()});
        if (opt.spp > 0) spp = uint32_t(std::min<uint64_t>(spp, opt.spp - r.spp));
        const uint32_t tile = uint32_t(std::clamp(work / spp, 64.0, double(npix)));
        p.sample_offset = uint32_t(r.spp);
        p.samples_per_dispatch = spp;
        p.accumulate = unflushed > 0 ? 1u : 0u;
        const auto pass_start = clock::now();
        for (uint32_t offset = 0; offset < npix; offset += tile) {
            p.pixel_offset = offset;
            p.pixel_count = std::min(tile, npix - offset);
            backend.dispatch(p);
        }
        const double pass_s = std::chrono::duration<double>(clock::now() - pass_start).count();
        r.spp += spp;
        unflushed += spp;
        // Retarget the dispatch size from this pass's rate.
        const double rate = double(spp) * npix / std::max(pass_s, 1e-6);
        work = std::clamp(rate * opt.dispatch_ms * 1e-3, 64.0, 64.0 * npix);

        bool done = opt.spp > 0 ? r.spp >= opt.spp : elapsed() >= opt.seconds;
        if (done || unflushed >= opt.flush_spp || opt.stop_when) flush();
        r.seconds = elapsed();
        if (opt.stop_when && opt.stop_when(r)) done = true;
        if (progress) {
            const double frac = opt.spp > 0 ? double(r.spp) / double(opt.spp)
                                            : std::min(1.0, r.seconds / opt.seconds);
            progress(frac, r);
        }
        if (done) break;
    }
    return r;
}

}  // namespace mcpt
