// Checkpoint and resume through `mcpt render --checkpoint`, and two renders on one device at
// once: a render killed with SIGKILL at
// random moments, several times, or stopped by a lost device, then run again to the end,
// writes the very file the uninterrupted render writes (bit for bit); a checkpoint from
// another scene, other options, another version, or a truncated or corrupted one is refused
// with a message saying which, and left as it was.
#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <random>
#include <string>

#include "test_util.h"

namespace mcpt {
namespace {

namespace fs = std::filesystem;
using test::run_mcpt;

std::string read_file(const fs::path& p) {
    return test::read_file(p.string());
}

void write_file(const fs::path& p, const std::string& bytes) {
    std::ofstream(p, std::ios::binary) << bytes;
}

fs::path temp(const std::string& name) {
    return test::temp_file(name);
}

// The render every test resumes: about 1 s of samples on PoCL or lavapipe, 16 groups of 16
// samples (several checkpoints 0.05 s apart fall inside it on a fast machine too), through the
// BVH on both APIs (`auto` renders the 12-triangle box without a tree on lavapipe).
std::string render_args(const std::string& api, const std::string& scene = "cornell",
                        int seed = 11) {
    return "render " + scene + " " + test::device_args(api) +
           " --width 96 --height 72 --spp 256 -q --tree bvh --seed " + std::to_string(seed);
}

// The uninterrupted render's file and its number of dispatches (what a lost device below is
// scaled to, so that it falls mid-render on any machine).
struct Whole {
    std::string file;
    int dispatches = 0;
};

Whole uninterrupted(const std::string& api) {
    const fs::path out = temp("whole_" + api + ".exr");
    fs::remove(out);
    const test::CliRun r = run_mcpt(render_args(api) + " --reproducible -v -o " + out.string());
    Whole w;
    EXPECT_EQ(r.status, 0) << r.output;
    const size_t at = r.output.find("dispatches: ");
    if (at != std::string::npos) w.dispatches = std::stoi(r.output.substr(at + 12));
    w.file = read_file(out);
    return w;
}

// The sample count a run resumed from ("resumed from PATH at N spp"; 0 if it did not).
uint64_t resumed_at(const std::string& output) {
    const size_t at = output.find("resumed from ");
    return at == std::string::npos ? 0 : std::stoull(output.substr(output.find(" at ", at) + 4));
}

TEST(Checkpoint, KilledAtRandomMomentsResumesBitForBit) {
    for (const std::string& api : test::test_apis()) {
        const Whole whole = uninterrupted(api);
        const fs::path ckpt = temp("killed_" + api + ".ckpt"), out = temp("killed_" + api + ".exr");
        const std::string args = render_args(api) + " --checkpoint " + ckpt.string() +
                                 " --checkpoint-every 0.05 -o " + out.string();
        // The render's window: from its first checkpoint to its end, uninterrupted (start-up,
        // the kernel or pipeline build, comes before and is not part of it).
        fs::remove(ckpt);
        const test::WatchedRun timing = test::run_mcpt_killed_after_write(args, ckpt.string(), 1e9);
        ASSERT_EQ(timing.status, 0) << timing.output;
        ASSERT_GE(timing.first_write, 0) << api << ": no checkpoint was written";
        const double window = timing.ended - timing.first_write;
        std::printf("%s: first checkpoint at %.2f s, render window %.2f s\n", api.c_str(),
                    timing.first_write, window);
        fs::remove(ckpt), fs::remove(out);
        // Killed at random moments (seeded): each run between 0 and 20% of the window after
        // its own first checkpoint, resuming the last one, three times; then run to the end.
        std::mt19937 rng(1234);
        int killed = 0;
        test::CliRun done;  // the run that completed
        for (int run = 0; run < 10 && done.status != 0; ++run) {
            const double then = window * std::uniform_real_distribution<double>(0.0, 0.2)(rng);
            const test::WatchedRun r =
                test::run_mcpt_killed_after_write(args, ckpt.string(), killed < 3 ? then : 1e9);
            ASSERT_GE(r.first_write, 0) << api << ": the run wrote no checkpoint\n" << r.output;
            if (r.status == 137) {
                ++killed;
                continue;
            }
            ASSERT_EQ(r.status, 0) << r.output;
            done = r;
        }
        ASSERT_EQ(done.status, 0) << api << ": no run completed";
        std::printf("%s: killed %d times after a checkpoint, completed from %llu spp\n",
                    api.c_str(), killed, (unsigned long long)resumed_at(done.output));
        EXPECT_GE(killed, 3) << api << ": the render ended before three kills";
        EXPECT_GT(resumed_at(done.output), 0u) << api << ": nothing was saved\n" << done.output;
        EXPECT_TRUE(test::same_bytes(out.string(), whole.file))
            << api << ": the resumed render differs";
        // Negative control: a render that is not reproducible differs in its bits.
        const fs::path other = temp("timed_" + api + ".exr");
        ASSERT_EQ(run_mcpt(render_args(api) + " -o " + other.string()).status, 0);
        EXPECT_FALSE(read_file(other) == whole.file) << api << ": the comparison cannot fail";
    }
}

TEST(Checkpoint, DeviceLostThenResumedBitForBit) {
    for (const std::string& api : test::test_apis()) {
        const Whole whole = uninterrupted(api);
        ASSERT_GE(whole.dispatches, 8) << api;
        const fs::path ckpt = temp("lost_" + api + ".ckpt"), out = temp("lost_" + api + ".exr");
        fs::remove(ckpt), fs::remove(out);
        const std::string args =
            render_args(api) + " --checkpoint " + ckpt.string() + " -o " + out.string();
        // Lost halfway through its dispatches: a group or more is saved.
        const test::CliRun lost =
            run_mcpt(args, "MCPT_LOSE_DEVICE_AFTER=" + std::to_string(whole.dispatches / 2));
        ASSERT_NE(lost.status, 0) << lost.output;
        ASSERT_TRUE(fs::exists(ckpt)) << lost.output;
        const test::CliRun again = run_mcpt(args);
        ASSERT_EQ(again.status, 0) << again.output;
        EXPECT_GT(resumed_at(again.output), 0u) << again.output;
        EXPECT_TRUE(test::same_bytes(out.string(), whole.file)) << api;
    }
}

TEST(Checkpoint, MismatchesAreRefusedAndLeftAlone) {
    const std::string api = "opencl";
    const fs::path ckpt = temp("refuse.ckpt"), out = temp("refuse.exr");
    fs::remove(ckpt);
    ASSERT_EQ(run_mcpt(render_args(api) + " --checkpoint " + ckpt.string() + " -o " + out.string())
                  .status,
              0);
    const std::string saved = read_file(ckpt);
    const auto refused = [&](const std::string& args, const std::string& expected) {
        const test::CliRun r =
            run_mcpt(args + " --checkpoint " + ckpt.string() + " -o " + out.string());
        EXPECT_NE(r.status, 0) << args << "\n" << r.output;
        EXPECT_NE(r.output.find(expected), std::string::npos) << args << "\n" << r.output;
    };
    refused(render_args(api, "furnace"), "written for another scene");
    refused(render_args(api, "cornell", 12), "written with other options: seed 11 (now 12)");
    refused(render_args(api) + " --max-depth 3", "max_depth 8 (now 3)");
    refused(render_args(api) + " --specialize off", "specialize on (now off)");
    EXPECT_TRUE(test::same_bytes(ckpt.string(), saved)) << "a refused checkpoint was overwritten";
    // Another version (the fingerprint's first line), a cut file, a flipped bit.
    std::string version = saved;
    const size_t v = version.find("mcpt=");
    ASSERT_NE(v, std::string::npos);
    version.replace(v + 5, 3, "9.9");
    write_file(ckpt, version);
    refused(render_args(api), "written by mcpt 9.9");
    write_file(ckpt, saved.substr(0, saved.size() / 2));
    refused(render_args(api), "truncated");
    std::string flipped = saved;
    flipped[flipped.size() - 100] ^= 0x10;
    write_file(ckpt, flipped);
    refused(render_args(api), "corrupted (checksum mismatch)");
    write_file(ckpt, "not a checkpoint");
    refused(render_args(api), "not an mcpt checkpoint");
    // The intact file still resumes.
    write_file(ckpt, saved);
    const test::CliRun ok =
        run_mcpt(render_args(api) + " --checkpoint " + ckpt.string() + " -o " + out.string());
    EXPECT_EQ(ok.status, 0) << ok.output;
    EXPECT_NE(ok.output.find("resumed from"), std::string::npos) << ok.output;
}

// Two `mcpt render` processes on one device at the same time both finish, each with the
// image it gives alone (reproducible mode: bit for bit).
TEST(Concurrency, TwoRendersOnOneDeviceAtOnce) {
    for (const std::string& api : test::test_apis()) {
        std::string alone[2], args[2];
        const fs::path together[2] = {temp("together0_" + api + ".exr"),
                                      temp("together1_" + api + ".exr")};
        for (int k = 0; k < 2; ++k) {
            args[k] = render_args(api, k == 0 ? "cornell" : "spheres", 20 + k) + " --reproducible";
            const fs::path out = temp("alone" + std::to_string(k) + "_" + api + ".exr");
            fs::remove(out), fs::remove(together[k]);
            ASSERT_EQ(run_mcpt(args[k] + " -o " + out.string()).status, 0);
            alone[k] = read_file(out);
        }
        const std::string bin = MCPT_BINARY;
        const test::CliRun both = test::run_command(
            bin + " " + args[0] + " -o " + together[0].string() + " & a=$!; " + bin + " " +
            args[1] + " -o " + together[1].string() + " & b=$!; wait $a && wait $b");
        ASSERT_EQ(both.status, 0) << both.output;
        for (int k = 0; k < 2; ++k)
            EXPECT_TRUE(test::same_bytes(together[k].string(), alone[k]))
                << api << ": render " << k << " differs";
        EXPECT_FALSE(alone[0] == alone[1]);
    }
}

}  // namespace
}  // namespace mcpt
