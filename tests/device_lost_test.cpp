// A device that fails mid-render: the session keeps exactly the samples it had read back
// (none of the failed pass), the image stays readable, a lost device is never used again, and
// `mcpt render` writes what it has and exits non-zero. Failures are injected: a backend
// wrapper that throws at the start of a chosen pass, and the backends' own
// lose_device_after (MCPT_LOSE_DEVICE_AFTER), which fails the way a lost device does.
#include <gtest/gtest.h>

#include <filesystem>

#include "common/error.h"
#include "common/render/session.h"
#include "common/scene/scene_load.h"
#include "test_util.h"

namespace mcpt {
namespace {

// A backend that fails when the `fail_at_pass`-th pass after arming starts (a pass starts
// with a round at pixel 0), after the passes before it completed on the device; it records
// each pass's samples per pixel, counts read-backs and notes how many passes had started at the
// last one.
class FailingBackend final : public Backend {
  public:
    explicit FailingBackend(std::unique_ptr<Backend> inner) : inner_(std::move(inner)) {}
    void arm(int fail_at_pass, bool lost) {
        fail_at_ = fail_at_pass, lost_ = lost, reads_ = 0, passes_at_read_ = 0;
        pass_spp_.clear();
    }
    int reads_since_armed() const { return reads_; }
    size_t passes_before_last_read() const { return passes_at_read_; }
    const std::vector<uint32_t>& pass_spp() const { return pass_spp_; }

    std::string description() const override { return inner_->description(); }
    const DeviceInfo& device() const override { return inner_->device(); }
    void load(const GpuScene& s, int w, int h, bool exact) override {
        inner_->load(s, w, h, exact);
    }
    const AccumLayout& accum_shape() const override { return inner_->accum_shape(); }
    void read_exact(std::vector<uint32_t>& out, uint32_t first, uint32_t count) override {
        ++reads_, passes_at_read_ = pass_spp_.size();
        inner_->read_exact(out, first, count);
    }
    uint32_t dispatch(const gpu::GpuParams& p) override {
        const bool pass_starts = p.round_start && p.pixel_offset == 0;
        if (pass_starts) pass_spp_.push_back(p.samples_per_dispatch);
        if (fail_at_ > 0 && pass_starts && int(pass_spp_.size()) == fail_at_) {
            fail_at_ = 0;
            if (lost_) throw DeviceLost("injected: device lost");
            throw Error("injected: out of device memory");
        }
        return inner_->dispatch(p);
    }
    void write_plan(const std::vector<uint32_t>& words) override { inner_->write_plan(words); }
    void read_accum(std::vector<float>& out, uint32_t pixels) override {
        ++reads_, passes_at_read_ = pass_spp_.size();
        inner_->read_accum(out, pixels);
    }
    double compile_seconds() const override { return inner_->compile_seconds(); }
    double device_seconds() const override { return inner_->device_seconds(); }
    uint32_t max_bounces_per_dispatch() const override {
        return inner_->max_bounces_per_dispatch();
    }
    uint32_t compiled_features() const override { return inner_->compiled_features(); }
    std::string layout() const override { return inner_->layout(); }
    std::string build_settings() const override { return inner_->build_settings(); }

  private:
    std::unique_ptr<Backend> inner_;
    int fail_at_ = 0, reads_ = 0;
    size_t passes_at_read_ = 0;
    std::vector<uint32_t> pass_spp_;
    bool lost_ = true;
};

class DeviceFailure : public ::testing::TestWithParam<std::string> {
  protected:
    // A session on the wrapped test device with 4 spp of the Cornell box read back.
    void start() {
        auto wrapped = std::make_unique<FailingBackend>(test::test_backend(GetParam()));
        fb_ = wrapped.get();
        session_ = std::make_unique<Session>(std::move(wrapped));
        session_->set_scene(load_scene("cornell"));
        session_->settings().width = session_->settings().height = 32;
        ASSERT_EQ(session_->render(1e6, 0, 4).spp, 4u);
        before_ = session_->image_rgba32f();
    }
    FailingBackend* fb_ = nullptr;
    std::unique_ptr<Session> session_;
    std::vector<float> before_;
};

double mean(const std::vector<float>& v) {
    double sum = 0;
    for (float x : v) sum += x;
    return sum / double(v.size());
}

// Two passes complete on the device, the third fails before they are read back (a render()
// reads back at most once a second after the first): the image is the 4 spp of before,
// exactly (the completed passes' sums are on the lost device; counting their samples would
// darken the image). On a machine so slow that a second passed, one read-back came first.
TEST_P(DeviceFailure, LostDeviceKeepsExactlyTheSamplesReadBack) {
    start();
    fb_->arm(3, true);
    EXPECT_THROW(session_->render(1e6, 0, 100000), DeviceLost);
    ASSERT_EQ(fb_->pass_spp().size(), 3u);
    if (fb_->reads_since_armed() == 0) {
        EXPECT_EQ(session_->spp(), 4u);
        EXPECT_EQ(session_->image_rgba32f(), before_);
    } else {
        // The passes read back are kept, exactly those (how many came before the read depends
        // on the device's dispatch budget: CPU devices' passes are longer).
        ASSERT_EQ(fb_->reads_since_armed(), 1);
        const size_t read = fb_->passes_before_last_read();
        ASSERT_GE(read, 1u);
        ASSERT_LE(read, 2u);
        uint64_t kept = 4;
        for (size_t k = 0; k < read; ++k) kept += fb_->pass_spp()[k];
        EXPECT_EQ(session_->spp(), kept);
        EXPECT_NEAR(mean(session_->image_rgba32f()), mean(before_), 0.1 * mean(before_));
    }
    const std::string out = testing::TempDir() + "/device_lost_" + GetParam() + ".exr";
    session_->write_image(out);
    EXPECT_GT(std::filesystem::file_size(out), 0u);
    // Never again on this device.
    try {
        session_->render(1e6, 0, 8);
        ADD_FAILURE() << "rendered on a lost device";
    } catch (const DeviceLost& e) {
        EXPECT_NE(std::string(e.what()).find("open a new session"), std::string::npos);
    }
}

// Another failure (out of memory, a driver error) at the first pass keeps the image as it
// was, and rendering goes on.
TEST_P(DeviceFailure, OtherFailureKeepsTheImageAndRenderingGoesOn) {
    start();
    fb_->arm(1, false);
    try {
        session_->render(1e6, 0, 1000);
        ADD_FAILURE() << "the injected failure did not reach the caller";
    } catch (const DeviceLost&) {
        ADD_FAILURE() << "an ordinary failure reported as a lost device";
    } catch (const Error&) {
    }
    EXPECT_EQ(session_->spp(), 4u);
    EXPECT_EQ(session_->image_rgba32f(), before_);
    EXPECT_EQ(session_->render(1e6, 0, 12).spp, 12u);
    EXPECT_NE(session_->image_rgba32f(), before_);
}

// Reproducible: whole groups go to exact sums on the device (fold_sums.h) and reach the host
// at a read-back. A device lost after many groups keeps those read back, a whole number of
// groups, and the image is exactly a fresh render of that many samples.
TEST_P(DeviceFailure, LostDeviceKeepsWholeGroupsReproducibly) {
    auto wrapped = std::make_unique<FailingBackend>(test::test_backend(GetParam()));
    FailingBackend* fb = wrapped.get();
    Session s(std::move(wrapped));
    s.set_scene(load_scene("cornell"));
    s.settings().width = s.settings().height = 32;
    s.settings().reproducible = true;
    ASSERT_EQ(s.render(1e6, 0, 32).spp, 32u);
    ASSERT_NE(s.backend().layout().find("exact sums on the device"), std::string::npos);
    fb->arm(40, true);
    EXPECT_THROW(s.render(1e6, 0, 100000), DeviceLost);
    const uint64_t kept = s.spp();
    EXPECT_EQ(kept % kReproducibleGroupSpp, 0u);
    // The groups folded since the last read-back are lost with the device: all of them where
    // none was read back (a render() reads back once a second).
    uint32_t completed = 0;
    for (size_t i = 0; i + 1 < fb->pass_spp().size(); ++i) completed += fb->pass_spp()[i];
    ASSERT_GE(completed, 2 * kReproducibleGroupSpp);
    EXPECT_LE(kept, 32u + completed);
    if (fb->reads_since_armed() == 0) {
        EXPECT_EQ(kept, 32u);
    }
    Session fresh(test::test_backend(GetParam()));
    fresh.set_scene(load_scene("cornell"));
    fresh.settings().width = fresh.settings().height = 32;
    fresh.settings().reproducible = true;
    ASSERT_EQ(fresh.render(1e6, 0, kept).spp, kept);
    EXPECT_EQ(s.image_rgba32f(), fresh.image_rgba32f()) << kept << " samples kept";
}

INSTANTIATE_TEST_SUITE_P(Backends, DeviceFailure, ::testing::ValuesIn(test::test_apis()),
                         [](const auto& info) { return info.param; });

// `mcpt render` of 16x16 pixels on `api` whose device reports itself lost at dispatch `after`;
// *out: the image path.
test::CliRun lost_render(const std::string& api, int after, const std::string& name,
                         std::string* out) {
    *out = testing::TempDir() + "/" + name + "_" + api + ".exr";
    std::filesystem::remove(*out);
    return test::run_mcpt(
        "render --backend " + api + " --width 16 --height 16 --spp 1000000 -q -o " + *out,
        "MCPT_LOSE_DEVICE_AFTER=" + std::to_string(after));
}

// The backends' own injection fails like a lost device; `mcpt render` says so, writes the
// samples taken before and exits non-zero.
TEST(DeviceFailureCli, RenderWritesTheImageSoFarAndFails) {
    for (const std::string& api : test::test_apis()) {
        std::string out;
        const test::CliRun r = lost_render(api, 50, "lost_cli", &out);
        EXPECT_NE(r.status, 0) << r.output;
        EXPECT_NE(r.output.find("injected by lose_device_after"), std::string::npos) << r.output;
        EXPECT_NE(r.output.find("rendered before the failure to " + out), std::string::npos)
            << r.output;
        ASSERT_TRUE(std::filesystem::exists(out)) << r.output;
        EXPECT_GT(std::filesystem::file_size(out), 0u);
    }
}

// Lost at its first dispatch, before any sample was read back: `mcpt render` says that none
// was kept and writes no image (on a GPU the first read-back can come after many dispatches).
TEST(DeviceFailureCli, RenderSaysWhenNoSampleWasKept) {
    for (const std::string& api : test::test_apis()) {
        std::string out;
        const test::CliRun r = lost_render(api, 1, "lost_first", &out);
        EXPECT_NE(r.status, 0) << r.output;
        EXPECT_NE(r.output.find("injected by lose_device_after"), std::string::npos) << r.output;
        EXPECT_NE(r.output.find("no samples were kept"), std::string::npos) << r.output;
        EXPECT_FALSE(std::filesystem::exists(out)) << r.output;
    }
}

}  // namespace
}  // namespace mcpt
