// Node steps and triangles per traversal iteration (KD_NODE_STEPS, KD_TRI_STEPS:
// common/gpu/traverse.h) change how the loop is cut, not what a ray visits: the plain loop
// body (one of each), and 1 and 1, 3 and 5 in the steps' loops give the same image, bit for
// bit, on both APIs (Vulkan: the module for GPUs, the one with the loops). So do overlapped
// steps (KD_OVERLAP, the default) and plain ones, in both Vulkan modules. A count out of range
// is refused.
#include <gtest/gtest.h>

#include <cstdio>
#include <cstdlib>

#include "common/error.h"
#include "common/render/session.h"
#include "common/scene/builtin_scenes.h"
#include "test_util.h"

namespace mcpt {
namespace {

class KdSteps : public ::testing::TestWithParam<std::string> {};

// A mesh through its k-d tree, 16 samples; nullptr: the variable unset (the default).
std::vector<float> render_mesh(const std::string& api, const char* nodes, const char* tris,
                               uint32_t seed = 3, const char* overlap = nullptr,
                               const char* reads = "storage", std::string* settings = nullptr) {
    const auto set = [](const char* name, const char* value) {
        if (value)
            setenv(name, value, 1);
        else
            unsetenv(name);
    };
    set("MCPT_KD_NODE_STEPS", nodes);
    set("MCPT_KD_TRI_STEPS", tris);
    set("MCPT_KD_OVERLAP", overlap);
    BackendOptions o;
    if (api == "vulkan") o.scene_reads = reads;  // storage: the module with the steps' loops
    // OpenCL for CPU devices loops over each leaf (no overlap): here the loop GPUs run.
    if (api == "opencl") o.extra_defines = "-DMCPT_KD_STEP_BY_STEP";
    Session s(test::test_backend(api, o));
    Scene scene = make_bumpy_sphere_scene(24);
    validate_scene(scene);
    s.set_scene(scene);
    s.settings().width = 48, s.settings().height = 40;
    s.settings().tree = "sah";
    s.settings().reproducible = true;
    s.settings().seed = seed;
    s.render(1e6, 0, 16);
    if (settings) *settings = s.backend().build_settings();
    set("MCPT_KD_NODE_STEPS", nullptr);
    set("MCPT_KD_TRI_STEPS", nullptr);
    set("MCPT_KD_OVERLAP", nullptr);
    return s.image_rgba32f();
}

TEST_P(KdSteps, StepsPerIterationGiveTheSameImage) {
    const std::vector<float> defaults = render_mesh(GetParam(), nullptr, nullptr);
    EXPECT_EQ(render_mesh(GetParam(), "1", "1"), defaults);
    EXPECT_EQ(render_mesh(GetParam(), "3", "5"), defaults);
    // Negative control: another seed is another image.
    EXPECT_NE(render_mesh(GetParam(), nullptr, nullptr, 4), defaults);
}

TEST_P(KdSteps, OverlappedStepsGiveTheSameImage) {
    for (const char* reads : {"storage", "texel"}) {
        if (GetParam() != "vulkan" && std::string(reads) == "texel") continue;
        const std::vector<float> overlapped =
            render_mesh(GetParam(), nullptr, nullptr, 3, "1", reads);
        EXPECT_EQ(render_mesh(GetParam(), nullptr, nullptr, 3, "0", reads), overlapped) << reads;
        EXPECT_EQ(render_mesh(GetParam(), nullptr, nullptr, 3, nullptr, reads), overlapped)
            << reads;
        EXPECT_EQ(render_mesh(GetParam(), "3", "5", 3, "1", reads), overlapped) << reads;
    }
}

// The variables reach the compiler: the build options OpenCL compiled with, the
// specialization constants Vulkan's pipeline was made with (without this, a backend that read
// the variables and never passed them on passed every test above).
TEST_P(KdSteps, StepsReachTheCompiler) {
    std::string plain, stepped;
    render_mesh(GetParam(), nullptr, nullptr, 3, nullptr, "storage", &plain);
    render_mesh(GetParam(), "3", "5", 3, "0", "storage", &stepped);
    std::printf("%s, default: %s\n%s, 3, 5, no overlap: %s\n", GetParam().c_str(),
                plain.c_str(), GetParam().c_str(), stepped.c_str());
    for (const char* want : {"KD_NODE_STEPS=3", "KD_TRI_STEPS=5", "KD_OVERLAP=0"}) {
        EXPECT_NE(stepped.find(want), std::string::npos) << want << " not in: " << stepped;
        EXPECT_EQ(plain.find(want), std::string::npos) << want << " in the default: " << plain;
    }
}

// A render with the variables set is refused with `message`; the variables unset after.
template <class Render>
void expect_refused(Render render, const std::string& message) {
    try {
        render();
        ADD_FAILURE() << "accepted; expected: " << message;
    } catch (const Error& e) {
        EXPECT_NE(std::string(e.what()).find(message), std::string::npos) << e.what();
    }
    unsetenv("MCPT_KD_NODE_STEPS");
    unsetenv("MCPT_KD_OVERLAP");
}

TEST_P(KdSteps, OutOfRangeIsRefused) {
    expect_refused([&] { render_mesh(GetParam(), "0", nullptr); },
                   "MCPT_KD_NODE_STEPS must be 1 to 32, not '0'");
    expect_refused([&] { render_mesh(GetParam(), nullptr, nullptr, 3, "2"); },
                   "MCPT_KD_OVERLAP must be 0 or 1, not '2'");
}

INSTANTIATE_TEST_SUITE_P(Backends, KdSteps, ::testing::ValuesIn(test::test_apis()),
                         [](const auto& info) { return info.param; });

}  // namespace
}  // namespace mcpt
