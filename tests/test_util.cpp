#include "test_util.h"

#include <sys/wait.h>

#include <array>
#include <cstdio>
#include <fstream>
#include <iterator>

#include "common/render/device_registry.h"

namespace mcpt::test {

std::unique_ptr<Backend> test_backend(const std::string& api, BackendOptions options) {
    if (api == "opencl") {
        if (options.device.empty()) options.device = test_opencl_device();
    } else if (const char* e = std::getenv("MCPT_TEST_VULKAN_DEVICE")) {
        if (options.device.empty()) options.device = e;
    }
    return open_device(api, options);
}

CliRun run_mcpt(const std::string& args, const std::string& env) {
    return run_command((env.empty() ? "" : "env " + env + " ") + std::string(MCPT_BINARY) + " " +
                       args);
}

CliRun run_mcpt_killed_after(double seconds, const std::string& args) {
    return run_command("timeout -s KILL " + std::to_string(seconds) + " " +
                       std::string(MCPT_BINARY) + " " + args);
}

CliRun run_command(const std::string& command) {
    const std::string cmd = command + " 2>&1";
    CliRun r;
    FILE* pipe = popen(cmd.c_str(), "r");
    if (!pipe) return r;
    std::array<char, 4096> buf{};
    while (fgets(buf.data(), int(buf.size()), pipe)) r.output += buf.data();
    const int st = pclose(pipe);
    r.status = WIFEXITED(st) ? WEXITSTATUS(st) : -1;
    return r;
}

std::string device_args(const std::string& api) {
    if (api == "opencl") return "--backend opencl --device " + test_opencl_device();
    const char* e = std::getenv("MCPT_TEST_VULKAN_DEVICE");
    return std::string("--backend vulkan") + (e ? " --device " + std::string(e) : "");
}

std::string read_file(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

}  // namespace mcpt::test
