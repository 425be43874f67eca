// The mcpt command line on bad input: a clear message and a non-zero exit, never a crash.
#include <gtest/gtest.h>
#include <sched.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "test_util.h"

namespace {

using mcpt::test::CliRun;
using mcpt::test::run_mcpt;

std::string temp_file(const std::string& name, const std::string& content) {
    const auto path = std::filesystem::temp_directory_path() / ("mcpt_cli_" + name);
    std::ofstream(path) << content;
    return path.string();
}

void expect_error(const std::string& args, const std::string& message) {
    const CliRun r = run_mcpt(args);
    EXPECT_EQ(r.status, 1) << args << "\n" << r.output;
    EXPECT_NE(r.output.find(message), std::string::npos)
        << "expected '" << message << "' for: " << args << "\n"
        << r.output;
}

TEST(Cli, MissingFile) {
    expect_error("render /nonexistent/scene.glb -q", "/nonexistent/scene.glb");
}

TEST(Cli, UnknownBuiltinScene) {
    expect_error("render nosuchscene -q", "cornell");
}

TEST(Cli, MalformedGltf) {
    const std::string path = temp_file("bad.gltf", "{ \"asset\": { \"version\": \"2.0\" ");
    expect_error("render " + path + " -q", "bad.gltf");
}

TEST(Cli, SceneWithoutLight) {
    // One unlit triangle: valid glTF, nothing to render.
    const std::string path = temp_file(
        "nolight.gltf",
        R"({"asset":{"version":"2.0"},"scene":0,"scenes":[{"nodes":[0]}],"nodes":[{"mesh":0}],
"meshes":[{"primitives":[{"attributes":{"POSITION":0}}]}],
"accessors":[{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3","min":[0,0,0],"max":[1,1,0]}],
"bufferViews":[{"buffer":0,"byteLength":36}],
"buffers":[{"byteLength":36,"uri":"data:application/octet-stream;base64,AAAAAAAAAAAAAAAAAACAPwAAAAAAAAAAAAAAAAAAgD8AAAAA"}]})");
    expect_error("render " + path + " -q", "no light");
}

// An environment scale that takes a finite texel past float: refused, naming the overflow
// (it was multiplied in float, and an Inf texel reached the device); the control renders.
TEST(Cli, EnvironmentScaleOverflowIsNamed) {
    const std::string out =
        (std::filesystem::temp_directory_path() / "mcpt_cli_env_scale.exr").string();
    const std::string args =
        "render cornell --background 1e30,1e30,1e30 --spp 1 --width 8 "
        "--height 8 -q -o " +
        out;
    expect_error(args + " --env-scale 1e10", "beyond single precision");
    const CliRun r = run_mcpt(args + " --env-scale 1e5");
    EXPECT_EQ(r.status, 0) << r.output;
}

// Lamps and a background: the light choice sees the background (lamps by contribution need
// lamps alone), so auto renders with the tree; asking for contribution is refused, named.
TEST(Cli, LampsWithABackgroundPickByTheTree) {
    const std::string out =
        (std::filesystem::temp_directory_path() / "mcpt_cli_lamps_bg.exr").string();
    const std::string args = "render " + std::string(MCPT_TEST_DATA_DIR) +
                             "/lamps.gltf --background 0.1,0.1,0.1 --spp 1 --width 8 --height 8 "
                             "--backend opencl -o " +
                             out;
    const CliRun r = run_mcpt(args);
    EXPECT_EQ(r.status, 0) << r.output;
    EXPECT_NE(r.output.find("light sampling: the tree"), std::string::npos) << r.output;
    expect_error(args + " --light-sampling contribution", "every light must be a lamp");
}

// Under taskset the k-d build takes the one CPU granted (it took one thread per core of the
// machine); the tree command says so.
TEST(Cli, TreeBuildUnderTasksetTakesTheGrantedCpu) {
    cpu_set_t set;
    ASSERT_EQ(sched_getaffinity(0, sizeof set, &set), 0);
    int cpu = 0;
    while (cpu < CPU_SETSIZE && !CPU_ISSET(cpu, &set)) ++cpu;
    const CliRun r = mcpt::test::run_command("taskset -c " + std::to_string(cpu) + " " +
                                             std::string(MCPT_BINARY) + " tree cornell");
    EXPECT_EQ(r.status, 0) << r.output;
    EXPECT_NE(r.output.find("on 1 thread\n"), std::string::npos) << r.output;
}

TEST(Cli, BadOptionsAreRejected) {
    // Bad input: exit status 1, as documented (CLI11's own codes are 105 and up).
    EXPECT_EQ(run_mcpt("render --tree octree").status, 1);
    EXPECT_EQ(run_mcpt("render --sampler halton").status, 1);
    EXPECT_EQ(run_mcpt("render --width 0").status, 1);
    EXPECT_EQ(run_mcpt("render --spp 4 --time 1").status, 1);
    EXPECT_EQ(run_mcpt("frobnicate").status, 1);
    EXPECT_EQ(run_mcpt("render --help").status, 0);
}

TEST(Cli, UnknownDevice) {
    expect_error("render --spp 1 -q --device no-such-device", "no-such-device");
}

TEST(Cli, UnsupportedImageFormat) {
    const std::string out = (std::filesystem::temp_directory_path() / "mcpt_cli.bmp").string();
    expect_error("render --spp 1 --width 8 --height 8 -q -o " + out, "unsupported");
}

TEST(Cli, RendersDefaultSceneToExr) {
    const std::string out = (std::filesystem::temp_directory_path() / "mcpt_cli.exr").string();
    std::filesystem::remove(out);
    const CliRun r = run_mcpt("render --spp 2 --width 32 --height 32 -q -o " + out);
    EXPECT_EQ(r.status, 0) << r.output;
    EXPECT_TRUE(std::filesystem::exists(out));
    EXPECT_NE(r.output.find("non-finite samples: 0"), std::string::npos) << r.output;
}

// The sampler is a build choice: -v names the independent sampler when asked for, and the two
// samplers draw different images from one seed.
TEST(Cli, SamplerChoice) {
    const auto dir = std::filesystem::temp_directory_path();
    const std::string a = (dir / "mcpt_cli_sobol.exr").string();
    const std::string b = (dir / "mcpt_cli_independent.exr").string();
    const std::string common = "render --spp 2 --width 16 --height 16 -q -v -o ";
    const CliRun sobol = run_mcpt(common + a);
    const CliRun independent = run_mcpt(common + b + " --sampler independent");
    ASSERT_EQ(sobol.status, 0) << sobol.output;
    ASSERT_EQ(independent.status, 0) << independent.output;
    EXPECT_EQ(sobol.output.find("independent sampler"), std::string::npos) << sobol.output;
    EXPECT_NE(independent.output.find("compiled for: "), std::string::npos);
    EXPECT_NE(independent.output.find("independent sampler"), std::string::npos)
        << independent.output;
    EXPECT_NE(mcpt::test::read_file(a), mcpt::test::read_file(b));
}

TEST(Cli, DevicesListsOpenCl) {
    const CliRun r = run_mcpt("devices");
    EXPECT_EQ(r.status, 0);
    EXPECT_NE(r.output.find("opencl:"), std::string::npos) << r.output;
}

// Sample counts and times are numbers in range: -1 is not 2^64 - 1 samples, 0 is not the
// default; the messages name the option (and no 300-digit number).
TEST(Cli, SampleCountAndTimeMustBePositive) {
    expect_error("render --spp -1 -q", "--spp");
    expect_error("render --spp 0 -q", "--spp");
    expect_error("render --time -1 -q", "--time");
    const CliRun r = run_mcpt("render --time -1 -q");
    EXPECT_EQ(r.output.find("179769"), std::string::npos) << r.output;
    expect_error("converge --spp -1", "--spp");
    expect_error("converge --time -1", "--time");
}

// The output's format and folder are checked before rendering (a million samples per pixel
// would otherwise run for hours first).
TEST(Cli, OutputCheckedBeforeRendering) {
    expect_error("render --spp 1000000 -q -o /nonexistent-folder/x.exr", "no folder");
    const std::string bmp = (std::filesystem::temp_directory_path() / "mcpt_cli.bmp").string();
    expect_error("render --spp 1000000 -q -o " + bmp, "unsupported image format");
}

// With one sample per pixel the error is unknown, and said to be.
TEST(Cli, OneSampleHasNoErrorEstimate) {
    const std::string out = (std::filesystem::temp_directory_path() / "mcpt_cli_1spp.png").string();
    const CliRun r = run_mcpt("render --spp 1 --width 8 --height 8 -q -o " + out);
    EXPECT_EQ(r.status, 0) << r.output;
    EXPECT_NE(r.output.find("unknown with 1 sample per pixel"), std::string::npos) << r.output;
    EXPECT_EQ(r.output.find("0.00%"), std::string::npos) << r.output;
}

// A negative default-scene index is an error, not scene 0.
TEST(Cli, NegativeSceneIndex) {
    const std::string path =
        temp_file("negscene.gltf",
                  R"({"asset":{"version":"2.0"},"scene":-3,"scenes":[{"nodes":[]}],"nodes":[]})");
    expect_error("render " + path + " -q", "default scene -3 is negative");
}

}  // namespace
