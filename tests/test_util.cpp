#include "test_util.h"

#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <fstream>
#include <iterator>
#include <thread>

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

namespace {

// A file's identity: the inode and modification time (an atomic rename gives a new inode).
std::string file_identity(const std::string& path) {
    struct stat st {};
    if (stat(path.c_str(), &st) != 0) return "";
    return std::to_string(st.st_ino) + ":" + std::to_string(st.st_mtim.tv_sec) + "." +
           std::to_string(st.st_mtim.tv_nsec);
}

}  // namespace

WatchedRun run_mcpt_killed_after_write(const std::string& args, const std::string& watched,
                                       double then) {
    using clock = std::chrono::steady_clock;
    WatchedRun r;
    char log_name[] = "/tmp/mcpt_watched_XXXXXX";
    const int log = mkstemp(log_name);
    if (log < 0) return r;
    const std::string before = file_identity(watched);
    const std::string command = "exec " + std::string(MCPT_BINARY) + " " + args;
    const auto start = clock::now();
    const auto since_start = [&] {
        return std::chrono::duration<double>(clock::now() - start).count();
    };
    const pid_t pid = fork();
    if (pid == 0) {
        dup2(log, 1), dup2(log, 2);
        execl("/bin/sh", "sh", "-c", command.c_str(), static_cast<char*>(nullptr));
        _exit(127);
    }
    int status = 0;
    bool killed = false;
    while (pid > 0) {
        if (waitpid(pid, &status, WNOHANG) == pid) break;
        const double t = since_start();
        if (r.first_write < 0 && file_identity(watched) != before) r.first_write = t;
        // Killed `then` seconds after the first write, or after 10 minutes in any case.
        if ((r.first_write >= 0 && t >= r.first_write + then) || t > 600) {
            kill(pid, SIGKILL);
            waitpid(pid, &status, 0);
            killed = true;
            break;
        }
        std::this_thread::sleep_for(std::chrono::milliseconds(2));
    }
    r.ended = since_start();
    r.status = killed ? 137 : WIFEXITED(status) ? WEXITSTATUS(status) : -1;
    r.output = read_file(log_name);
    close(log);
    unlink(log_name);
    return r;
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

::testing::AssertionResult same_bytes(const std::string& path, const std::string& expected) {
    const std::string got = read_file(path);
    if (expected.empty()) return ::testing::AssertionFailure() << "the reference file is empty";
    if (got.empty()) return ::testing::AssertionFailure() << path << " is missing or empty";
    if (got != expected)
        return ::testing::AssertionFailure() << path << " differs (" << got.size() << " bytes, "
                                             << expected.size() << " expected)";
    return ::testing::AssertionSuccess();
}

::testing::AssertionResult every_device_took_chunks(const std::string& output, int devices) {
    for (int d = 0; d < devices; ++d) {
        const std::string key = "  device " + std::to_string(d) + ": ";
        const size_t at = output.find(key);
        if (at == std::string::npos)
            return ::testing::AssertionFailure() << "no line for device " << d;
        const size_t eol = output.find('\n', at);
        const std::string line = output.substr(at, eol - at);
        const size_t chunks = line.find(" chunks,");
        const size_t colon = line.rfind(": ", chunks);
        if (chunks == std::string::npos || colon == std::string::npos)
            return ::testing::AssertionFailure() << "no chunk count in: " << line;
        const long n = std::strtol(line.c_str() + colon + 2, nullptr, 10);
        if (n < 1) return ::testing::AssertionFailure() << "took no chunk: " << line;
    }
    if (output.find("  device " + std::to_string(devices) + ": ") != std::string::npos)
        return ::testing::AssertionFailure() << "more than " << devices << " devices";
    return ::testing::AssertionSuccess();
}

}  // namespace mcpt::test
