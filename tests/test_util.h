// Helpers shared by the tests: the OpenCL device under test, simple statistics, a scoped
// environment variable, runs of the mcpt binary and each test's own temporary folder.
#pragma once

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "common/render/render_loop.h"
#include "opencl/cl_backend.h"

namespace mcpt::test {

// The OpenCL device the tests run on: $MCPT_TEST_OPENCL_DEVICE (index or name), else the
// first CPU device (PoCL in CI), else the best device.
inline std::string test_opencl_device() {
    if (const char* e = std::getenv("MCPT_TEST_OPENCL_DEVICE")) return e;
    for (const DeviceInfo& d : list_opencl_devices())
        if (d.type == "cpu") return std::to_string(d.index);
    return "";
}

inline std::unique_ptr<Backend> test_opencl_backend(const std::string& defines = "",
                                                    bool fast_math = false) {
    BackendOptions o;
    o.device = test_opencl_device();
    o.extra_defines = defines;
    o.fast_math = fast_math;
    return make_opencl_backend(o);
}

// The device under test of a backend API: OpenCL as above, Vulkan from
// $MCPT_TEST_VULKAN_DEVICE (index or name), else the best (lavapipe in CI).
std::unique_ptr<Backend> test_backend(const std::string& api, BackendOptions options = {});

// An environment variable set (value nullptr: unset) for the object's lifetime, then as it
// was before (nested ones too), also when the scope is left by an exception.
class ScopedEnv {
  public:
    ScopedEnv(const char* name, const char* value) : name_(name) {
        if (const char* before = std::getenv(name)) before_ = before;
        set(value);
    }
    ~ScopedEnv() { set(before_ ? before_->c_str() : nullptr); }
    ScopedEnv(const ScopedEnv&) = delete;
    ScopedEnv& operator=(const ScopedEnv&) = delete;

  private:
    void set(const char* value) {
        if (value)
            setenv(name_, value, 1);
        else
            unsetenv(name_);
    }
    const char* name_;
    std::optional<std::string> before_;
};

// The backends the stability tests run on: both APIs where Vulkan is built.
inline std::vector<std::string> test_apis() {
#if MCPT_WITH_VULKAN
    return {"opencl", "vulkan"};
#else
    return {"opencl"};
#endif
}

// The mcpt binary run with `args` (stderr into stdout), with `env` ("NAME=value ...") added
// to its environment: its exit status (-1 if killed by a signal) and output.
struct CliRun {
    int status = -1;
    std::string output;
};
CliRun run_mcpt(const std::string& args, const std::string& env = "");
// The mcpt binary run with `args` while `watched` (a checkpoint file) is watched: once this
// run has written it (a new file: created, or replaced by an atomic rename), the run is killed
// with SIGKILL `then` seconds later if still running (status 137). Times measured from the
// run's own first write, so that a kill falls mid-render whatever the machine's speed and its
// start-up time. `first_write` and `ended` are the seconds from the start to that write (-1:
// none) and to the run's end.
struct WatchedRun : CliRun {
    double first_write = -1, ended = 0;
};
WatchedRun run_mcpt_killed_after_write(const std::string& args, const std::string& watched,
                                       double then);
// A shell command (stderr into stdout).
CliRun run_command(const std::string& command);
// The command line's options for the test device of `api` ("--backend opencl --device 0").
std::string device_args(const std::string& api);
// A file's bytes ("" if it cannot be read).
std::string read_file(const std::string& path);
// A path for `name` in the running test's own folder (created; TempDir/mcpt/SUITE/TEST):
// ctest runs tests as processes side by side, and two that shared a file name raced (one
// removed the file another was about to read).
// (Inline: the unit tests' binary links no test_util.cpp.)
inline std::string temp_file(const std::string& name) {
    const ::testing::TestInfo* t = ::testing::UnitTest::GetInstance()->current_test_info();
    std::string suite = t ? t->test_suite_name() : "none", test = t ? t->name() : "none";
    for (std::string* s : {&suite, &test}) std::replace(s->begin(), s->end(), '/', '_');
    const std::filesystem::path dir =
        std::filesystem::path(::testing::TempDir()) / "mcpt" / suite / test;
    std::filesystem::create_directories(dir);
    return (dir / name).string();
}
// The file at `path` holds exactly `expected`, and neither is empty (two runs that wrote no
// file would otherwise compare equal).
::testing::AssertionResult same_bytes(const std::string& path, const std::string& expected);
// Every device of a several-device run took a chunk: `render`'s lines "  device K: NAME: C
// chunks" for K = 0 .. devices - 1, each with C >= 1 (byte equality holds when one did all).
::testing::AssertionResult every_device_took_chunks(const std::string& output, int devices);

// Mean radiance over all pixels, channels and samples, with its standard error (samples are
// independent across pixels, so the pooled variance applies).
struct MeanEstimate {
    double mean = 0, std_error = 0;
    double z(double expected) const { return (mean - expected) / std_error; }
};

inline MeanEstimate pooled_mean(const RenderResult& r) {
    double n = 0, s = 0, s2 = 0;
    for (size_t i = 0; i < r.nonfinite.size(); ++i) {
        const double count = double(r.spp) - r.nonfinite[i];
        n += 3 * count;
        for (int c = 0; c < 3; ++c) s += r.sum[3 * i + c], s2 += r.sum_sq[3 * i + c];
    }
    MeanEstimate e;
    e.mean = s / n;
    const double var = (s2 / n - e.mean * e.mean) * n / (n - 1);
    // Channels of one sample are correlated (grey scene): count samples, not channels.
    e.std_error = std::sqrt(var / (n / 3));
    return e;
}

// Channel c's mean over every sample and its standard error.
struct ChannelMean {
    double mean = 0, std_error = 0;
    // Within 4.5 standard errors of `expected`, and within 1e-5 of it where the samples barely
    // vary (the clear channel: every path brings back exactly the background, up to rounding).
    bool near(double expected) const {
        return std::abs(mean - expected) <= 4.5 * std_error + 1e-5 * expected;
    }
    double z(double expected) const { return (mean - expected) / std_error; }
};
inline ChannelMean channel_mean(const RenderResult& res, int c) {
    double n = 0, s = 0, s2 = 0;
    for (size_t i = 0; i < res.nonfinite.size(); ++i) {
        n += double(res.spp) - res.nonfinite[i];
        s += res.sum[3 * i + size_t(c)], s2 += res.sum_sq[3 * i + size_t(c)];
    }
    ChannelMean m;
    m.mean = s / n;
    m.std_error = std::sqrt(std::max(0.0, (s2 / n - m.mean * m.mean) * n / (n - 1)) / n);
    return m;
}

}  // namespace mcpt::test
