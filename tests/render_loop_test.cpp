// The progressive render loop on a fake device that accumulates in float like the kernels:
// 10^7 samples per pixel stay within float rounding of the exact mean (the host adds device
// sums in double), while a float running sum — the negative control — drifts far beyond it.
#include "common/render/render_loop.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <functional>
#include <map>

#include "common/gpu/fold_sums.h"
#include "common/render/adaptive.h"

namespace mcpt {
namespace {

// Sample i of any pixel has radiance value(i); the device sums in float per dispatch.
float value(uint64_t i) {
    return 0.1f + 0.05f * float((i * 2654435761u) % 1000u) / 1000.f;
}

// Each sample takes `bounces` bounces; dispatches carry unfinished samples across, like the
// kernels' step_slot().
class FakeBackend final : public Backend {
  public:
    std::string description() const override { return "fake"; }
    const DeviceInfo& device() const override { return info_; }
    void load(const GpuScene&, int w, int h, bool exact) override {
        accum_.assign(size_t(w) * h * 8, 0.f);
        layout_ = accum_layout(uint64_t(w) * h, 0, exact && offer_exact);
        slots_.assign(layout_.slots, Slot{});
        exact_.assign(size_t(layout_.exact_pixels) * EXACT_VEC4_PER_PIXEL, glm::uvec4(0));
    }
    const AccumLayout& accum_shape() const override { return layout_; }
    // Exact sums as the kernels fold them: the device code itself (common/gpu/fold_sums.h).
    void read_exact(std::vector<uint32_t>& out, uint32_t first, uint32_t count) override {
        out.resize(size_t(count) * EXACT_VEC4_PER_PIXEL * 4);
        std::memcpy(out.data(), &exact_.at(size_t(first) * EXACT_VEC4_PER_PIXEL), out.size() * 4);
    }
    uint32_t fold(const gpu::GpuParams& p) {
        ++folds;
        uint32_t out_of_range = 0;
        for (uint32_t i = p.pixel_offset; i < p.pixel_offset + p.pixel_count; ++i) {
            glm::uvec4* e = &exact_.at(size_t(i) * EXACT_VEC4_PER_PIXEL);
            const float* a = &accum_[8 * size_t(i)];
            gpu::ExactPixel px;
            std::copy(e, e + EXACT_VEC4_PER_PIXEL, px.w);
            const gpu::FoldStep f =
                gpu::fold_pixel(glm::vec4(a[0], a[1], a[2], a[3]),
                                glm::vec4(a[4], a[5], a[6], a[7]), px, p.fold_sums);
            std::copy(f.px.w, f.px.w + EXACT_VEC4_PER_PIXEL, e);
            out_of_range |= f.ok ? 0u : 1u;
        }
        return out_of_range;
    }
    uint32_t dispatch(const gpu::GpuParams& p) override {
        if (p.fold_sums) return fold(p);
        ++dispatches;
        most_samples_per_round = std::max(most_samples_per_round, p.samples_per_dispatch);
        most_bounces_per_dispatch = std::max(most_bounces_per_dispatch, p.bounce_budget);
        uint32_t active = 0;
        for (uint32_t k = 0; k < p.pixel_count; ++k) {
            float* a = &accum_[8 * size_t(p.pixel_offset + k)];
            Slot& slot = slots_.at(p.pixel_offset + k - p.state_base);
            if (p.round_start) {
                slot = Slot{p.sample_offset, p.samples_per_dispatch, 0};
                if (p.sample_plan) {
                    const size_t at =
                        PLAN_WORDS_PER_SLOT * size_t(p.pixel_offset + k - p.state_base);
                    slot = Slot{plan_.at(at), plan_.at(at + 1), 0};
                }
                if (!p.accumulate) std::fill(a, a + 8, 0.f);
            }
            for (uint32_t budget = p.bounce_budget; slot.left > 0 && budget > 0;) {
                const uint32_t run = std::min(budget, bounces - slot.done);
                slot.done += run, budget -= run;
                if (slot.done < bounces) break;
                const float v = pixel_value(p.pixel_offset + k, slot.sample);
                if (record) taken[p.pixel_offset + k].push_back(slot.sample);
                for (int c = 0; c < 3; ++c) a[c] += v, a[4 + c] += v * v;
                a[7] += 1.f;
                slot = Slot{slot.sample + 1, slot.left - 1, 0};
            }
            active += slot.left > 0;
        }
        return active;
    }
    void write_plan(const std::vector<uint32_t>& words) override { plan_ = words; }
    void read_accum(std::vector<float>& out, uint32_t) override { out = accum_; }
    // Sample i of pixel p: value(i), or around it with 100 times the spread in noisy pixels.
    float pixel_value(uint32_t p, uint64_t i) const {
        return noisy && noisy(p) ? 0.15f + 100.f * (value(i) - 0.125f) : value(i);
    }
    std::function<bool(uint32_t)> noisy;
    bool record = false;  // keep every pixel's sample indices in `taken`
    std::map<uint32_t, std::vector<uint32_t>> taken;
    double compile_seconds() const override { return 0; }
    uint32_t compiled_features() const override { return FEATURE_ALL; }
    std::string layout() const override { return "fake"; }
    std::string build_settings() const override { return ""; }
    double device_seconds() const override { return 0; }
    uint32_t max_bounces_per_dispatch() const override { return cap; }
    bool offer_exact = true;  // room for exact sums when a reproducible render asks
    size_t dispatches = 0, folds = 0;
    uint32_t most_samples_per_round = 0, most_bounces_per_dispatch = 0;
    uint32_t cap = 1u << 20, bounces = 1;
    DeviceInfo info_;  // type "" (neither GPU nor CPU) unless a test sets it

  private:
    struct Slot {
        uint32_t sample = 0, left = 0, done = 0;
    };
    AccumLayout layout_;
    std::vector<float> accum_;
    std::vector<glm::uvec4> exact_;
    std::vector<Slot> slots_;
    std::vector<uint32_t> plan_;
};

// Reproducible: each group's float sums added exactly on the device (the fake runs the device
// code, fold_sums.h) give the sums of the host's exact additions, bit for bit.
TEST(RenderLoop, ExactSumsOnTheDeviceEqualTheHosts) {
    RenderOptions o;
    o.width = 7, o.height = 5;
    o.spp = 16 * 37 + 5;  // the last, partial group shown on top of the exact sums
    o.group_spp = 16;
    FakeBackend device, host;
    host.offer_exact = false;
    device.noisy = host.noisy = [](uint32_t p) { return p % 3 == 0; };
    const RenderResult a = render(device, GpuScene{}, Camera{}, o);
    const RenderResult b = render(host, GpuScene{}, Camera{}, o);
    EXPECT_GE(device.folds, 37u);
    EXPECT_EQ(host.folds, 0u);
    EXPECT_EQ(a.spp, o.spp);
    EXPECT_EQ(a.sum, b.sum);
    EXPECT_EQ(a.sum_sq, b.sum_sq);
    EXPECT_EQ(a.rays, b.rays);
    EXPECT_EQ(a.nonfinite, b.nonfinite);
    // Negative control: without the partial group's samples, another image.
    o.spp -= 5;
    EXPECT_NE(render(host, GpuScene{}, Camera{}, o).sum, a.sum);
}

TEST(RenderLoop, TenMillionSamplesDoNotDrift) {
    FakeBackend backend;
    GpuScene scene;
    RenderOptions o;
    o.width = 1, o.height = 1;
    o.spp = 10'000'000;
    const RenderResult r = render(backend, scene, Camera{}, o);
    ASSERT_EQ(r.spp, o.spp);
    // Exact mean in double, and the naive float running sum.
    double exact = 0;
    float naive = 0;
    for (uint64_t i = 0; i < o.spp; ++i) exact += value(i), naive += value(i);
    exact /= double(o.spp);
    const double mean = r.mean_image()[0];
    EXPECT_NEAR(mean / exact, 1.0, 1e-6);
    EXPECT_GT(std::abs(double(naive) / double(o.spp) / exact - 1.0), 5e-5)
        << "negative control: a float running sum should drift";
    EXPECT_LE(backend.most_samples_per_round, o.flush_spp);
    EXPECT_DOUBLE_EQ(r.rays, double(o.spp));
}

TEST(RenderLoop, EveryPixelGetsEverySample) {
    FakeBackend backend;
    GpuScene scene;
    RenderOptions o;
    o.width = 37, o.height = 23;  // not a multiple of any tile size
    o.spp = 300;
    const RenderResult r = render(backend, scene, Camera{}, o);
    for (size_t i = 0; i < size_t(o.width) * o.height; ++i) {
        double exact = 0;
        for (uint64_t s = 0; s < o.spp; ++s) exact += value(s);
        ASSERT_NEAR(r.sum[3 * i], exact, 1e-4 * exact) << "pixel " << i;
    }
    EXPECT_DOUBLE_EQ(r.rays, double(o.spp) * o.width * o.height);
}

// Paths far longer than a backend's bounce budget per dispatch (CPU Vulkan drivers) continue
// across dispatches: the budget is kept, and every sample still arrives, exactly once.
TEST(RenderLoop, PathsLongerThanTheBounceBudgetContinue) {
    FakeBackend backend;
    backend.cap = 7;
    backend.bounces = 50;
    GpuScene scene;
    RenderOptions o;
    o.width = 7, o.height = 5;
    o.spp = 40;
    const RenderResult r = render(backend, scene, Camera{}, o);
    EXPECT_LE(backend.most_bounces_per_dispatch, 7u);
    EXPECT_GE(backend.dispatches, size_t(o.spp) * 50 / 7);
    EXPECT_EQ(r.spp, o.spp);
    EXPECT_DOUBLE_EQ(r.rays, double(o.spp) * o.width * o.height);
    for (size_t i = 0; i < size_t(o.width) * o.height; ++i) {
        double exact = 0;
        for (uint64_t s = 0; s < o.spp; ++s) exact += value(s);
        ASSERT_NEAR(r.sum[3 * i], exact, 1e-4 * exact) << "pixel " << i;
    }
}

// Adaptive sampling: each pixel takes sample indices 0 .. n-1, each once (its sums and count
// are those samples'); the mean count is the spp asked for; the noisy pixels get the samples
// (sigma 100 times the others'), the others far fewer.
TEST(RenderLoop, AdaptiveSamplesFollowTheNoiseAndArriveOnce) {
    FakeBackend backend;
    const int w = 24, h = 16;
    backend.noisy = [&](uint32_t p) { return p % w < 4 && p / w < 4; };
    backend.record = true;
    GpuScene scene;
    RenderOptions o;
    o.width = w, o.height = h;
    o.spp = 256;
    o.adaptive = true;
    const RenderResult r = render(backend, scene, Camera{}, o);
    ASSERT_EQ(r.samples.size(), size_t(w) * h);
    EXPECT_EQ(r.spp, o.spp);
    double total = 0, noisy = 0, quiet_max = 0;
    for (uint32_t i = 0; i < uint32_t(w * h); ++i) {
        std::vector<uint32_t> idx = backend.taken[i];
        std::sort(idx.begin(), idx.end());
        ASSERT_EQ(double(idx.size()), r.samples[i]) << "pixel " << i;
        for (size_t k = 0; k < idx.size(); ++k) ASSERT_EQ(idx[k], k) << "pixel " << i;
        double exact = 0;
        for (uint32_t s : idx) exact += backend.pixel_value(i, s);
        ASSERT_NEAR(r.sum[3 * i], exact, 1e-4 * std::abs(exact) + 1e-3) << "pixel " << i;
        const double n = r.samples[i];
        total += n;
        // 16 noisy pixels; those beyond kAdaptiveRadius of them (the pooling) are quiet.
        if (backend.noisy(i)) noisy += n;
        const uint32_t far = 4 + kAdaptiveRadius;
        if (i % w >= far || i / w >= far) quiet_max = std::max(quiet_max, n);
    }
    EXPECT_NEAR(total / (w * h), double(o.spp), 1.0);
    EXPECT_DOUBLE_EQ(r.rays, total);
    EXPECT_GT(noisy / 16, 8 * quiet_max) << "the noisy pixels should take the samples";
    EXPECT_LE(quiet_max, 0.25 * o.spp);
    // Uniform sampling, the control: every pixel alike.
    o.adaptive = false;
    const RenderResult u = render(backend, scene, Camera{}, o);
    EXPECT_TRUE(u.samples.empty());
    EXPECT_EQ(u.spp, o.spp);
}

// CPU devices get long dispatches (their cost per dispatch), GPUs and devices held to the
// phone's limits short ones; options that name a duration keep it.
TEST(RenderLoop, DispatchBudgetFollowsTheDevice) {
    DeviceInfo gpu, cpu, phone;
    gpu.type = "gpu", cpu.type = "cpu", phone.type = "cpu";
    phone.phone_limits = true;
    EXPECT_EQ(dispatch_budget_ms(gpu), kGpuDispatchMs);
    EXPECT_EQ(dispatch_budget_ms(cpu), kCpuDispatchMs);
    EXPECT_EQ(dispatch_budget_ms(phone), kGpuDispatchMs);
    EXPECT_GT(kCpuDispatchMs, kGpuDispatchMs);
    EXPECT_EQ(dispatch_budget_ms(cpu, 45), 45);
    FakeBackend backend;
    backend.info_.type = "cpu";
    RenderOptions o;
    o.width = o.height = 4;
    EXPECT_EQ(ProgressiveRender(backend, GpuScene{}, Camera{}, o).dispatch_ms(), kCpuDispatchMs);
    o.dispatch_ms = 45;
    EXPECT_EQ(ProgressiveRender(backend, GpuScene{}, Camera{}, o).dispatch_ms(), 45);
}

TEST(RenderLoop, RejectsBadSizes) {
    FakeBackend backend;
    GpuScene scene;
    RenderOptions o;
    o.width = 0;
    o.spp = 1;
    EXPECT_THROW(render(backend, scene, Camera{}, o), std::exception);
    o.width = 4, o.height = 4, o.spp = 0, o.seconds = 0;
    EXPECT_THROW(render(backend, scene, Camera{}, o), std::exception);
}

}  // namespace
}  // namespace mcpt

namespace mcpt {

// The accumulation buffer holds every pixel's sums while they fit in the largest buffer, and
// a window of pixels with their sums and path state when they do not; it never exceeds it.
TEST(AccumLayout, WholeImageOrAWindowWithinTheLargestBuffer) {
    const uint64_t mib = 1ull << 20;
    const AccumLayout small = accum_layout(100, 0);
    EXPECT_FALSE(small.window);
    EXPECT_EQ(small.sum_pixels, 100u);
    EXPECT_EQ(small.slots, 100u);
    EXPECT_EQ(small.bytes, (100u * 2 + 100u * 6 + 1 + 50) * 16);  // 50: the sample plan
    // 1024^2 under 128 MiB: all sums (32 MiB), the path state fitted beside them.
    const AccumLayout k1 = accum_layout(1024 * 1024, 128 * mib);
    EXPECT_FALSE(k1.window);
    EXPECT_EQ(k1.sum_pixels, 1024u * 1024u);
    EXPECT_LE(k1.bytes, 128 * mib);
    EXPECT_GT(k1.slots, 900000u);
    // 2048^2: the sums alone are 128 MiB: a window.
    const AccumLayout k2 = accum_layout(2048 * 2048, 128 * mib);
    EXPECT_TRUE(k2.window);
    EXPECT_EQ(k2.sum_pixels, k2.slots);
    EXPECT_LE(k2.bytes, 128 * mib);
    EXPECT_GT(k2.bytes, 127 * mib);
    EXPECT_EQ(k2.plan_offset() + k2.plan_bytes(), k2.bytes);
    EXPECT_EQ(k2.pending_offset(), k2.plan_offset() - 16);
    // Unknown limit: everything, state capped at MAX_STATE_SLOTS.
    const AccumLayout big = accum_layout(4096 * 4096, 0);
    EXPECT_FALSE(big.window);
    EXPECT_EQ(big.slots, MAX_STATE_SLOTS);
}

}  // namespace mcpt
