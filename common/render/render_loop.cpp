#include "common/render/render_loop.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstring>
#include <thread>

#include "common/error.h"
#include "common/io/host_cpus.h"
#include "common/render/adaptive.h"
#include "common/render/device_limits.h"

namespace mcpt {

std::vector<float> RenderResult::mean_image() const {
    const size_t n = size_t(width) * size_t(height);
    std::vector<float> img(3 * n);
    for_ranges(n, [&](size_t begin, size_t end) {
        for (size_t i = begin; i < end; ++i)
            for (int c = 0; c < 3; ++c) img[3 * i + c] = channel_stats(*this, i, c).mean;
    });
    return img;
}

std::vector<float> RenderResult::std_error_image() const {
    const size_t n = size_t(width) * size_t(height);
    std::vector<float> err(3 * n);
    for_ranges(n, [&](size_t begin, size_t end) {
        for (size_t i = begin; i < end; ++i)
            for (int c = 0; c < 3; ++c) err[3 * i + c] = channel_stats(*this, i, c).std_error;
    });
    return err;
}

double RenderResult::mean_radiance() const {
    const std::vector<float> img = mean_image();
    double total = 0;
    for (float v : img) total += v;
    return img.empty() ? 0 : total / double(img.size());
}

double RenderResult::relative_error() const {
    // One pass, nothing allocated (sessions ask after every render() call).
    const size_t n = size_t(width) * size_t(height);
    if (spp < 2 || n == 0) return HUGE_VAL;
    // Sums per block of pixels on threads, then the blocks in order: the same bits on any
    // number of threads.
    constexpr size_t kBlock = size_t(1) << 14;
    const size_t blocks = (n + kBlock - 1) / kBlock;
    std::vector<double> block_err(blocks), block_radiance(blocks);
    for_ranges(
        blocks,
        [&](size_t begin, size_t end) {
            for (size_t b = begin; b < end; ++b) {
                double err = 0, radiance = 0;
                for (size_t i = b * kBlock; i < std::min(n, (b + 1) * kBlock); ++i)
                    for (int c = 0; c < 3; ++c) {
                        const ChannelStats st = channel_stats(*this, i, c);
                        radiance += st.mean, err += st.std_error;
                    }
                block_err[b] = err, block_radiance[b] = radiance;
            }
        },
        4);
    double err = 0, radiance = 0;
    for (size_t b = 0; b < blocks; ++b) err += block_err[b], radiance += block_radiance[b];
    if (!(radiance > 0)) return HUGE_VAL;
    return err / radiance;
}

void RenderResult::materialize() {
    if (exact.empty()) return;
    for_ranges(size_t(width) * size_t(height), [this](size_t begin, size_t end) {
        for (size_t i = begin; i < end; ++i)
            for (int c = 0; c < 3; ++c) {
                sum[3 * i + c] = from_exact(exact[6 * i + c]);
                sum_sq[3 * i + c] = from_exact(exact[6 * i + 3 + c]);
            }
    });
}

void accumulate_sums(RenderResult& to, const RenderResult& part) {
    accumulate_sums(to, std::vector<const RenderResult*>{&part});
}

void accumulate_sums(RenderResult& to, const std::vector<const RenderResult*>& parts) {
    size_t from = 0;
    if (to.sum.empty() && !parts.empty()) {
        const uint64_t first = to.first;
        to = *parts[0];
        to.first = first;
        from = 1;
    }
    for (size_t p = from; p < parts.size(); ++p) {
        const RenderResult& part = *parts[p];
        if (part.width != to.width || part.height != to.height)
            throw Error("sums of " + std::to_string(part.width) + "x" +
                        std::to_string(part.height) + " pixels added to " +
                        std::to_string(to.width) + "x" + std::to_string(to.height));
        if (part.exact.empty() != to.exact.empty())
            throw Error("exact (reproducible) and inexact sums cannot be added");
    }
    if (from == parts.size()) return;
    // Pixel ranges in threads of their own; within a range, blocks small enough to stay in
    // the cache while every part is added to them (one pass over the image for all parts).
    std::atomic<bool> fits{true};
    for_ranges(to.nonfinite.size(), [&](size_t begin, size_t end) {
        constexpr size_t kBlock = 2048;
        for (size_t b0 = begin; b0 < end; b0 += kBlock) {
            const size_t b1 = std::min(end, b0 + kBlock);
            for (size_t p = from; p < parts.size(); ++p) {
                const RenderResult& part = *parts[p];
                if (!to.exact.empty()) {
                    for (size_t k = 6 * b0; k < 6 * b1; ++k)
                        if (!add_exact(to.exact[k], part.exact[k])) fits.store(false);
                } else {
                    for (size_t k = 3 * b0; k < 3 * b1; ++k)
                        to.sum[k] += part.sum[k], to.sum_sq[k] += part.sum_sq[k];
                }
                for (size_t i = b0; i < b1; ++i) to.nonfinite[i] += part.nonfinite[i];
            }
        }
    });
    if (!fits.load())
        throw Error("radiance too large for reproducible sums (beyond 7.6e22 per pixel)");
    for (size_t p = from; p < parts.size(); ++p) {
        to.spp += parts[p]->spp;
        to.rays += parts[p]->rays;
        to.nonfinite_total += parts[p]->nonfinite_total;
        to.seconds += parts[p]->seconds;
    }
}

void add_sums(RenderResult& to, const RenderResult& part) {
    if (part.first != to.first + to.spp)
        throw Error("sums of samples " + std::to_string(part.first) + ".. added to samples " +
                    std::to_string(to.first) + ".." + std::to_string(to.first + to.spp) +
                    ": not adjacent");
    accumulate_sums(to, part);
}

RenderResult render(Backend& backend, const GpuScene& scene, const Camera& camera,
                    const RenderOptions& opt, const ProgressFn& progress) {
    if (opt.width <= 0 || opt.height <= 0 || opt.width > 16384 || opt.height > 16384) {
        throw Error("image size must be between 1x1 and 16384x16384");
    }
    backend.load(scene, opt.width, opt.height, opt.group_spp > 0);
    return render_loaded(backend, scene, camera, opt, progress);
}

uint64_t host_bytes_per_pixel() {
    // Double sums and squares (6), invalid count (1); the device's float sums (8).
    return 7 * sizeof(double) + 8 * sizeof(float);
}

double dispatch_budget_ms(const DeviceInfo& device, double requested) {
    if (requested > 0) return requested;
    return device.type == "cpu" && !device.phone_limits ? kCpuDispatchMs : kGpuDispatchMs;
}

ProgressiveRender::ProgressiveRender(Backend& backend, const GpuScene& scene, const Camera& camera,
                                     const RenderOptions& opt)
    : backend_(backend), opt_(opt) {
    opt_.dispatch_ms = dispatch_budget_ms(backend.device(), opt_.dispatch_ms);
    npix_ = uint32_t(opt.width) * uint32_t(opt.height);
    // The host accumulators, checked against the memory available before allocating (at
    // most half of it: the process and the system need the rest).
    const uint64_t need =
        uint64_t(npix_) * (host_bytes_per_pixel() +
                           (opt.group_spp > 0 ? 7 * sizeof(double) + 6 * sizeof(ExactSum) : 0));
    const uint64_t available = host_memory_available();
    if (need > available / 2) {
        throw OutOfMemory("image too large for this host: " + std::to_string(opt.width) + "x" +
                          std::to_string(opt.height) + " needs " + human_bytes(need) +
                          " of host memory for its sums; " + human_bytes(available) +
                          " available (at most half is used)");
    }
    p_ = scene.params;
    set_camera(p_, camera, opt.width, opt.height);
    p_.max_depth = opt.max_depth;
    p_.rr_depth = opt.rr_depth;
    p_.seed = opt.seed;
    p_.light_scale = opt.light_scale;
    r_.width = opt.width, r_.height = opt.height;
    r_.sum.assign(3 * size_t(npix_), 0.0);
    r_.sum_sq.assign(3 * size_t(npix_), 0.0);
    r_.nonfinite.assign(npix_, 0.0);
    // The accumulation buffer the backend allocated for this size (gpu_scene.h).
    const AccumLayout& layout = backend.accum_shape();
    slots_ = layout.slots;
    windowed_ = layout.window;
    p_.accum_window = windowed_ ? 1u : 0u;
    // The device's float sums as read back (allocated, and touched, now: not in a render).
    device_sums_.resize(size_t(npix_) * 8);
    if (opt.adaptive && opt.group_spp > 0)
        throw Error("adaptive sampling is not reproducible: its sample counts follow the noise");
    if (opt.group_spp > 0) {
        group_ = std::min(opt.group_spp, opt.flush_spp);
        settled_ = r_;
        settled_.exact.assign(6 * size_t(npix_), 0);
        // Each group's sums go to exact sums on the device where it keeps them (fold_group()).
        exact_on_device_ = layout.exact_pixels == npix_ && !windowed_;
        p_.exact_vec4 = exact_on_device_ ? uint32_t(layout.exact_offset() / 16) : 0u;
    }
    // Work per dispatch (pixel-samples), adapted to the measured rate.
    work_ = std::min<double>(npix_, 4096);
}

void ProgressiveRender::read_device_sums() {
    // A windowed buffer's sums were read back tile by tile during the pass.
    if (!windowed_) backend_.read_accum(device_sums_, 0);
}

void ProgressiveRender::add_device_sums(RenderResult& to) const {
    // The sums, in pixel ranges on threads of their own (a 1024x1024 group is six million
    // exact additions); reproducible: the group's float sums added exactly (exact_sums.h).
    const bool exact = !to.exact.empty();
    std::atomic<bool> fits{true};
    // Counts per pixel are whole numbers (floats exact below 2^24): summed as integers on the
    // threads, the totals are the same in any order.
    std::atomic<uint64_t> nonfinite{0}, rays{0};
    for_ranges(npix_, [&](size_t begin, size_t end) {
        bool ok = true;
        uint64_t range_nonfinite = 0, range_rays = 0;
        for (size_t i = begin; i < end; ++i) {
            range_nonfinite += uint64_t(device_sums_[8 * i + 3]);
            range_rays += uint64_t(device_sums_[8 * i + 7]);
            const float* a = &device_sums_[8 * i];
            for (int c = 0; c < 3; ++c) {
                if (exact) {
                    ExactSum s, q;
                    ok = ok && to_exact(a[c], s) && to_exact(a[4 + c], q) &&
                         add_exact(to.exact[6 * i + c], s) && add_exact(to.exact[6 * i + 3 + c], q);
                } else {
                    to.sum[3 * i + c] += a[c];
                    to.sum_sq[3 * i + c] += a[4 + c];
                }
            }
            to.nonfinite[i] += a[3];
        }
        if (!ok) fits.store(false);
        nonfinite += range_nonfinite, rays += range_rays;
    });
    to.nonfinite_total += nonfinite.load();
    to.rays += double(rays.load());
    if (!fits.load())
        throw Error(
            "radiance too large for reproducible sums (beyond 7.6e22 per pixel): render "
            "without --reproducible or checkpoints");
}

void ProgressiveRender::settle() {
    if (unflushed_ == 0) return;
    // Reproducible: only whole groups reach the (exact) settled sums.
    const bool group_end = group_ == 0 || unflushed_ >= group_;
    if (group_end && exact_on_device_) {
        fold_group();
        unflushed_ = 0;
        return;  // the samples reach the host at the next sync_exact()
    }
    read_device_sums();
    if (group_ == 0) {
        add_device_sums(r_);
    } else if (group_end) {
        add_device_sums(settled_);
        settled_.spp = r_.spp;
        stale_ = true;
    }
    // Adaptive, warming up: keep the sums of the warm-up's first half (adaptive.h).
    if (opt_.adaptive && r_.spp == kAdaptiveWarmupSpp / 2) half_ = r_;
    if (group_end) unflushed_ = 0;
    flushed_ = true;
    flushed_at_ = std::chrono::steady_clock::now();
}

void ProgressiveRender::fold_group() {
    // One dispatch over the image, tracing nothing; FOLD_STORE after a sync (the host has the
    // groups before). It sets the pending word where a sum leaves the exact range.
    gpu::GpuParams p = p_;
    p.fold_sums = device_groups_ ? FOLD_ADD : FOLD_STORE;
    p.pixel_offset = 0, p.pixel_count = npix_;
    if (backend_.dispatch(p) != 0)
        throw Error(
            "radiance too large for reproducible sums (beyond 7.6e22 per pixel): render "
            "without --reproducible or checkpoints");
    device_groups_ = true;
    device_spp_ = r_.spp;
}

void ProgressiveRender::sync_exact() {
    if (!device_groups_) return;
    // In chunks of pixels: read back, then added on threads, pixel ranges apart.
    const uint32_t chunk = std::min<uint32_t>(npix_, 1u << 18);
    const size_t words = EXACT_VEC4_PER_PIXEL * 4;
    std::atomic<bool> fits{true};
    uint64_t nonfinite = 0, rays = 0;
    for (uint32_t first = 0; first < npix_; first += chunk) {
        const uint32_t n = std::min(chunk, npix_ - first);
        backend_.read_exact(exact_words_, first, n);
        std::atomic<uint64_t> chunk_nonfinite{0}, chunk_rays{0};
        for_ranges(n, [&](size_t begin, size_t end) {
            bool ok = true;
            uint64_t nf = 0, ry = 0;
            for (size_t k = begin; k < end; ++k) {
                const uint32_t* w = &exact_words_[words * k];
                const size_t i = first + k;
                for (int j = 0; j < 6; ++j) {
                    ExactSum v;
                    std::memcpy(&v, w + 4 * j, sizeof(v));  // little-endian, low word first
                    ok = ok && add_exact(settled_.exact[6 * i + j], v);
                }
                const uint64_t pixel_nonfinite = w[24] | uint64_t(w[25]) << 32;
                settled_.nonfinite[i] += double(pixel_nonfinite);
                nf += pixel_nonfinite;
                ry += w[26] | uint64_t(w[27]) << 32;
            }
            chunk_nonfinite += nf, chunk_rays += ry;
            if (!ok) fits.store(false);
        });
        nonfinite += chunk_nonfinite.load(), rays += chunk_rays.load();
    }
    if (!fits.load())
        throw Error(
            "radiance too large for reproducible sums (beyond 7.6e22 per pixel): render "
            "without --reproducible or checkpoints");
    settled_.nonfinite_total += nonfinite;
    settled_.rays += double(rays);
    settled_.spp = device_spp_;
    device_groups_ = false;
    synced_once_ = true;
    stale_ = true;
    flushed_ = true;
    flushed_at_ = std::chrono::steady_clock::now();
}

void ProgressiveRender::flush() {
    // Reproducible, inside a group: the device keeps adding to its sums; show them on top of
    // the sums settled at the last group end.
    const bool partial = group_ > 0 && unflushed_ > 0 && unflushed_ < group_;
    if (partial) {
        read_device_sums();
        flushed_ = true;
        flushed_at_ = std::chrono::steady_clock::now();
    } else {
        settle();
    }
    if (group_ == 0) return;
    sync_exact();
    show_settled();
    if (partial) add_device_sums(r_);
}

void ProgressiveRender::show_settled() {
    // The image's doubles, from the exact sums (r_ keeps its sample count and render time).
    if (stale_) settled_.materialize(), stale_ = false;
    // Copied in pixel ranges on threads (r_'s arrays are image-sized already).
    r_.sum.resize(settled_.sum.size()), r_.sum_sq.resize(settled_.sum_sq.size());
    r_.nonfinite.resize(settled_.nonfinite.size());
    for_ranges(npix_, [this](size_t begin, size_t end) {
        std::copy(settled_.sum.begin() + 3 * begin, settled_.sum.begin() + 3 * end,
                  r_.sum.begin() + 3 * begin);
        std::copy(settled_.sum_sq.begin() + 3 * begin, settled_.sum_sq.begin() + 3 * end,
                  r_.sum_sq.begin() + 3 * begin);
        std::copy(settled_.nonfinite.begin() + begin, settled_.nonfinite.begin() + end,
                  r_.nonfinite.begin() + begin);
    });
    r_.rays = settled_.rays, r_.nonfinite_total = settled_.nonfinite_total;
}

double ProgressiveRender::seconds_since_flush() const {
    // Nothing on the host yet, or (exact sums on the device) no whole group: at once.
    if (!flushed_ || (device_groups_ && !synced_once_)) return HUGE_VAL;
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - flushed_at_).count();
}

void ProgressiveRender::discard_unflushed() {
    r_.spp -= unflushed_;
    unflushed_ = 0;
    // Groups in the device's exact sums, not read back, are gone with it.
    if (device_groups_) r_.spp = settled_.spp, device_groups_ = false;
    if (group_ > 0) show_settled();
}

const RenderResult& ProgressiveRender::settled() {
    if (group_ == 0) return r_;
    sync_exact();
    if (stale_) settled_.materialize(), stale_ = false;
    settled_.seconds = r_.seconds;
    return settled_;
}

void ProgressiveRender::restore(const RenderResult& saved) {
    if (saved.width != r_.width || saved.height != r_.height)
        throw Error("saved sums are " + std::to_string(saved.width) + "x" +
                    std::to_string(saved.height) + ", the image is " + std::to_string(r_.width) +
                    "x" + std::to_string(r_.height));
    if (group_ > 0 && (saved.exact.size() != 6 * size_t(npix_) || saved.first % group_ != 0 ||
                       saved.spp % group_ != 0))
        throw Error("saved sums are not a reproducible render's (exact, whole groups)");
    begun_empty_ = false;
    r_ = saved;
    base_ = saved.first;
    device_groups_ = false;
    if (group_ > 0) {
        settled_ = saved;
        r_.exact.clear();
        r_.exact.shrink_to_fit();
    }
    unflushed_ = 0;
}

void ProgressiveRender::begin_at(uint64_t first) {
    if (group_ > 0 && first % group_ != 0)
        throw Error("a reproducible chunk starts at a multiple of " + std::to_string(group_) +
                    " samples, not at " + std::to_string(first));
    // Zeros in place (the arrays are image-sized and reused chunk after chunk).
    const auto zero = [&](RenderResult& r) {
        for_ranges(npix_, [&r](size_t begin, size_t end) {
            std::fill(r.sum.begin() + 3 * begin, r.sum.begin() + 3 * end, 0.0);
            std::fill(r.sum_sq.begin() + 3 * begin, r.sum_sq.begin() + 3 * end, 0.0);
            std::fill(r.nonfinite.begin() + begin, r.nonfinite.begin() + end, 0.0);
            if (!r.exact.empty())
                std::fill(r.exact.begin() + 6 * begin, r.exact.begin() + 6 * end, ExactSum(0));
        });
        r.samples.clear();
        r.spp = 0, r.first = first, r.rays = 0, r.nonfinite_total = 0, r.seconds = 0;
    };
    zero(r_);
    if (group_ > 0) zero(settled_), stale_ = false;
    begun_empty_ = true;
    device_groups_ = false;
    base_ = first;
    unflushed_ = 0;
}

void ProgressiveRender::restart(uint32_t seed, float light_scale, uint64_t first) {
    if (opt_.adaptive) throw Error("an adaptive render starts over with a new loop");
    opt_.seed = p_.seed = seed;
    opt_.light_scale = p_.light_scale = light_scale;
    // Session::reset() began empty sums at `first` already (no sample since): not zeroed twice.
    if (!begun_empty_ || base_ != first) begin_at(first);
    flushed_ = synced_once_ = false;
    device_spp_ = 0;
}

void ProgressiveRender::continue_at(uint64_t first) {
    if (group_ > 0 && (first % group_ != 0 || unflushed_ != 0))
        throw Error("a reproducible chunk starts at a multiple of " + std::to_string(group_) +
                    " samples, after whole groups");
    // The next sample is `first`; the sums keep counting (unsigned arithmetic wraps back).
    base_ = first - r_.spp;
}

uint32_t ProgressiveRender::pass(uint64_t max_spp) {
    begun_empty_ = false;
    // Adaptive, after the warm-up: samples where the noise is.
    if (opt_.adaptive && r_.spp >= kAdaptiveWarmupSpp) return adaptive_pass(max_spp);
    // Every pixel gets `spp` more samples, in tiles of at most `work` pixel-samples (and at
    // most the path-state slots).
    // A windowed buffer is read back whole every pass: passes of about a second amortize that
    // (the tiles stay sized to the dispatch target; paths continue across dispatches).
    const double work = windowed_ ? work_ * 1e3 / opt_.dispatch_ms : work_;
    // At most up to the next flush (reproducible: the next group end; adaptive: the end of
    // either half of the warm-up).
    uint32_t until_flush = (group_ > 0 ? group_ : opt_.flush_spp) - unflushed_;
    if (opt_.adaptive) {
        const uint64_t half = kAdaptiveWarmupSpp / 2;
        until_flush =
            uint32_t(std::min<uint64_t>(until_flush, (r_.spp < half ? half : 2 * half) - r_.spp));
    }
    uint32_t spp = uint32_t(std::clamp(std::floor(work / npix_), 1.0, double(until_flush)));
    // Tiles of about the work target, whatever the samples below.
    uint32_t tile_spp = spp;
    if (group_ > 0 && !windowed_ && spp < until_flush) {
        // Reproducible: as few passes to the group end as passes of this size take (each
        // round ends in a tail of long paths, and a short pass before the group end would add
        // a round): passes of at most twice the size (dispatches stay within the target).
        const uint32_t passes = until_flush / spp;
        spp = (until_flush + passes - 1) / passes;
    }
    if (windowed_ && group_ > 0) {
        // Reproducible through a window, whose sums restart every pass: a pass renders a whole
        // group (or up to max_spp), and a group that max_spp cut short is rendered again
        // whole, from its first sample, by the next pass.
        max_spp = max_spp == UINT64_MAX ? max_spp : max_spp + unflushed_;
        r_.spp -= unflushed_;
        unflushed_ = 0;
        spp = tile_spp = group_;
    }
    spp = uint32_t(std::max<uint64_t>(1, std::min<uint64_t>(spp, max_spp)));
    const double dispatch_s =
        run_tiles(tile_for(std::min(spp, tile_spp)), spp, uint32_t(base_ + r_.spp), nullptr);
    r_.spp += spp;
    unflushed_ += spp;
    retarget(double(spp) * npix_, dispatch_s);
    if (unflushed_ >= (group_ > 0 ? group_ : opt_.flush_spp) || windowed_ || opt_.adaptive)
        settle();
    return spp;
}

uint32_t ProgressiveRender::adaptive_pass(uint64_t max_spp) {
    // After the warm-up: sigma from its two halves, once (adaptive.h).
    if (sigma_.empty()) {
        sigma_ = adaptive_sigma(half_, r_, opt_.adaptive_own_noise);
        half_ = RenderResult{};
        r_.samples.assign(npix_, double(r_.spp));
    }
    // The pass's samples: half of those so far (early passes re-plan often), at most about a
    // second's worth and flush_spp / 4 per pixel on average; one pixel takes at most 4
    // flush_spp (its device float sum stays short).
    double total = 0;
    for (double n : r_.samples) total += n;
    const double mean_cap = std::max(1.0, opt_.flush_spp / 4.0);
    double budget = std::min({0.5 * total, work_ * 1e3 / opt_.dispatch_ms, mean_cap * npix_});
    if (max_spp != UINT64_MAX) budget = std::min(budget, double(max_spp) * npix_);
    budget = std::max(budget, double(npix_));
    const double mean = budget / npix_;
    plan_ = plan_samples(sigma_, r_.samples, uint64_t(budget), 4 * opt_.flush_spp);
    // Rounds sized to the mean; pixels that take more continue in further dispatches.
    const uint32_t spp = uint32_t(std::ceil(mean));
    const double dispatch_s = run_tiles(tile_for(spp), spp, 0, &plan_);
    read_device_sums();
    add_device_sums(r_);
    double added = 0;
    for (size_t i = 0; i < npix_; ++i) r_.samples[i] += plan_[i], added += plan_[i];
    r_.spp = uint64_t((total + added) / double(npix_) + 1e-9);
    retarget(added, dispatch_s);
    flushed_ = true;
    flushed_at_ = std::chrono::steady_clock::now();
    return spp;
}

void ProgressiveRender::retarget(double samples, double dispatch_s) {
    // From this pass's dispatch rate (read-backs of a window are not dispatches: counting them
    // would shrink the tiles they are amortized over).
    const double rate = samples / std::max(dispatch_s, 1e-6);
    work_ = std::clamp(rate * opt_.dispatch_ms * 1e-3, 64.0, 64.0 * npix_);
}

uint32_t ProgressiveRender::tile_for(uint32_t spp) const {
    return uint32_t(std::clamp(work_ / spp, 64.0, double(std::min(npix_, slots_))));
}

double ProgressiveRender::run_tiles(uint32_t tile, uint32_t spp, uint32_t first,
                                    const std::vector<uint32_t>* plan) {
    using clock = std::chrono::steady_clock;
    // Tiles of equal size (no sliver at the end).
    const uint32_t tiles = (npix_ + tile - 1) / tile;
    tile = (npix_ + tiles - 1) / tiles;
    const uint32_t cap = std::max(1u, backend_.max_bounces_per_dispatch());
    const double target_s = opt_.dispatch_ms * 1e-3;
    p_.sample_offset = first;
    p_.samples_per_dispatch = spp;
    p_.sample_plan = plan ? 1u : 0u;
    // A window is overwritten by each tile's round and read back after it.
    p_.accumulate = unflushed_ > 0 && !windowed_ ? 1u : 0u;
    p_.state_slots = slots_;
    const auto start = clock::now();
    double dispatch_s = 0;  // this pass's dispatches, without read-backs
    const uint32_t max_tile = std::min(npix_, slots_);
    for (uint32_t offset = 0; offset < npix_; offset += p_.pixel_count) {
        p_.pixel_offset = p_.state_base = offset;
        p_.pixel_count = std::min(tile, npix_ - offset);
        if (plan) {
            // The tile's plan, by slot: each pixel's first sample index and its samples.
            plan_words_.resize(size_t(p_.pixel_count) * PLAN_WORDS_PER_SLOT);
            for (uint32_t k = 0; k < p_.pixel_count; ++k) {
                plan_words_[2 * k] = uint32_t(r_.samples[offset + k]);
                plan_words_[2 * k + 1] = (*plan)[offset + k];
            }
            backend_.write_plan(plan_words_);
        }
        // A round: start the tile's samples, continue their paths until none is left.
        p_.round_start = 1;
        const double round_before = dispatch_s;
        for (uint32_t active = 1; active > 0; p_.round_start = 0) {
            // Per pixel: the budget per sample times the samples, within the device's cap.
            p_.bounce_budget = uint32_t(std::min<uint64_t>(uint64_t(bounce_budget_) * spp, cap));
            const auto t0 = clock::now();
            active = backend_.dispatch(p_);
            const double t = std::chrono::duration<double>(clock::now() - t0).count();
            dispatch_s_.push_back(float(t));
            dispatch_s += t;
            if (t > longest_dispatch_s_) longest_dispatch_s_ = t, longest_at_ = dispatch_s_.size();
            // The budget bounds dispatches whose paths outlast it: halve it after such a dispatch
            // over the target, double it while they stay well under. (A dispatch that finished
            // its paths and still overran has too many pixels: the tile shrinks after the pass.)
            if (active > 0 && t > target_s && bounce_budget_ > 1)
                bounce_budget_ /= 2;
            else if (active > 0 && t < 0.4 * target_s && uint64_t(bounce_budget_) * spp < cap)
                bounce_budget_ *= 2;
        }
        // Rounds far under the target (the first pass starts from a guess of 4096 pixels):
        // larger tiles for the rest of the pass, up to eight times, toward the target.
        const double round_s = dispatch_s - round_before;
        if (round_s < 0.5 * target_s && tile < max_tile && !plan)
            tile = uint32_t(std::min<double>(
                max_tile, tile * std::min(8.0, target_s / std::max(round_s, 1e-6))));
        if (windowed_) {
            // The tile's sums, staged until the pass completes (a failure mid-pass adds none).
            backend_.read_accum(window_sums_, p_.pixel_count);
            std::copy_n(window_sums_.begin(), size_t(p_.pixel_count) * 8,
                        device_sums_.begin() + size_t(offset) * 8);
        }
    }
    last_pass_s_ = std::chrono::duration<double>(clock::now() - start).count();
    return dispatch_s;
}

double ProgressiveRender::median_dispatch_seconds() const {
    if (dispatch_s_.empty()) return 0;
    std::vector<float> v = dispatch_s_;
    std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
    return v[v.size() / 2];
}

RenderResult render_loaded(Backend& backend, const GpuScene& scene, const Camera& camera,
                           const RenderOptions& opt, const ProgressFn& progress) {
    using clock = std::chrono::steady_clock;
    if (opt.spp == 0 && !(opt.seconds > 0)) throw Error("give a sample count or a time budget");
    ProgressiveRender pr(backend, scene, camera, opt);
    RenderResult& r = pr.result();
    const auto start = clock::now();
    auto elapsed = [&] { return std::chrono::duration<double>(clock::now() - start).count(); };
    while (true) {
        pr.pass(opt.spp > 0 ? opt.spp - r.spp : UINT64_MAX);
        bool done = opt.spp > 0 ? r.spp >= opt.spp : elapsed() >= opt.seconds;
        if (done || opt.stop_when) pr.flush();
        r.seconds = elapsed();
        if (opt.stop_when && opt.stop_when(r)) done = true;
        if (progress) {
            const double frac = opt.spp > 0 ? double(r.spp) / double(opt.spp)
                                            : std::min(1.0, r.seconds / opt.seconds);
            progress(frac, r);
        }
        if (done) break;
    }
    return std::move(r);
}

}  // namespace mcpt
