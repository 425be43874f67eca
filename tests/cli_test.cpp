// The mcpt command line on bad input: a clear message and a non-zero exit, never a crash.
#include <gtest/gtest.h>

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

TEST(Cli, BadOptionsAreRejected) {
    EXPECT_NE(run_mcpt("render --tree octree").status, 0);
    EXPECT_NE(run_mcpt("render --width 0").status, 0);
    EXPECT_NE(run_mcpt("render --spp 4 --time 1").status, 0);
    EXPECT_NE(run_mcpt("frobnicate").status, 0);
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

TEST(Cli, DevicesListsOpenCl) {
    const CliRun r = run_mcpt("devices");
    EXPECT_EQ(r.status, 0);
    EXPECT_NE(r.output.find("opencl:"), std::string::npos) << r.output;
}

}  // namespace
