// Beyond one device through the command line: several devices in one process, MPI ranks
// (mpirun, Open MPI) and parts merged afterwards (render --part I/N, mcpt merge) all write the
// file one reproducible render writes, byte for byte; merge refuses parts that do not make one
// job; a rank killed with SIGKILL or whose device is lost ends the job naming it, and the last
// checkpoint resumes with another number of ranks to the same file.
#include <gtest/gtest.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "app/commands.h"
#include "app/reduction_tree.h"
#include "common/error.h"
#include "test_util.h"

namespace mcpt {
namespace {

namespace fs = std::filesystem;
using test::run_mcpt;

fs::path temp(const std::string& name) {
    return test::temp_file(name);
}

// About a second of samples on PoCL; chunks of 0.05 s, so every device takes several.
std::string job(int spp = 512, int seed = 3, const std::string& devices = "") {
    return "render cornell " + (devices.empty() ? test::device_args("opencl") : devices) +
           " --width 64 --height 48 -q --chunk-seconds 0.05 --spp " + std::to_string(spp) +
           " --seed " + std::to_string(seed);
}

// The file one reproducible render on one device writes.
std::string one_device(int spp = 512) {
    const fs::path out = temp("one_" + std::to_string(spp) + ".exr");
    fs::remove(out);
    const test::CliRun r = run_mcpt(job(spp) + " --reproducible -o " + out.string());
    EXPECT_EQ(r.status, 0) << r.output;
    const std::string bytes = test::read_file(out.string());
    EXPECT_FALSE(bytes.empty()) << r.output;
    return bytes;
}

TEST(ScaleOut, SeveralDevicesInOneProcessWriteOneDevicesFile) {
    const std::string one = one_device();
    ASSERT_FALSE(one.empty());
    const fs::path out = temp("three.exr");
    const std::string dev = test::device_args("opencl");
    const std::string d = dev.substr(dev.find("--device"));
    const test::CliRun r =
        run_mcpt(job() + " " + d + " " + d + " --reproducible -o " + out.string());
    ASSERT_EQ(r.status, 0) << r.output;
    EXPECT_TRUE(test::every_device_took_chunks(r.output, 3)) << r.output;
    EXPECT_TRUE(test::same_bytes(out.string(), one)) << r.output;
    // PoCL and lavapipe together: both take chunks (the images agree statistically:
    // SeveralDevices.PoclAndLavapipeTogetherAgreeWithOneDevice).
    const test::CliRun mixed =
        run_mcpt(job(512, 3, "--device opencl:" + d.substr(d.find(' ') + 1) + " --device vulkan") +
                 " -o " + temp("mixed.exr").string());
    ASSERT_EQ(mixed.status, 0) << mixed.output;
    EXPECT_NE(mixed.output.find("device 1: vulkan"), std::string::npos) << mixed.output;
    EXPECT_TRUE(test::every_device_took_chunks(mixed.output, 2)) << mixed.output;
}

TEST(ScaleOut, MergedPartsAreOneRenderBitForBit) {
    const std::string one = one_device();
    std::string parts;
    for (int i = 1; i <= 4; ++i) {
        const fs::path p = temp("part" + std::to_string(i) + ".ckpt");
        fs::remove(p);
        const test::CliRun r =
            run_mcpt(job() + " --part " + std::to_string(i) + "/4 --checkpoint " + p.string() +
                     " -o " + temp("part.png").string());
        ASSERT_EQ(r.status, 0) << r.output;
        parts += " " + p.string();
    }
    const fs::path out = temp("merged.exr");
    const test::CliRun m = run_mcpt("merge" + parts + " -o " + out.string());
    ASSERT_EQ(m.status, 0) << m.output;
    EXPECT_TRUE(test::same_bytes(out.string(), one)) << m.output;
}

TEST(ScaleOut, MergeRefusesWhatIsNotOneJob) {
    auto part = [](const std::string& name, const std::string& which, int seed) {
        const fs::path p = temp(name);
        fs::remove(p);
        const test::CliRun r = run_mcpt(job(128, seed) + " --part " + which + " --checkpoint " +
                                        p.string() + " -o " + temp("p.png").string());
        EXPECT_EQ(r.status, 0) << r.output;
        return p.string();
    };
    const std::string a = part("a.ckpt", "1/2", 3), b = part("b.ckpt", "2/2", 3);
    const std::string other_seed = part("c.ckpt", "2/2", 4);
    const std::string out = " -o " + temp("m.exr").string();
    struct Case {
        std::string args, says;
    };
    const fs::path whole = temp("whole.ckpt");
    fs::remove(whole);
    ASSERT_EQ(
        run_mcpt(job(128) + " --checkpoint " + whole.string() + " -o " + temp("w.png").string())
            .status,
        0);
    for (const Case& c : {Case{a, "miss 64 of 128 samples"}, Case{a + " " + a, "overlaps"},
                          Case{a + " " + other_seed, "another job"},
                          Case{a + " " + whole.string(), "not a part"}}) {
        const test::CliRun r = run_mcpt("merge " + c.args + out);
        EXPECT_EQ(r.status, 1) << c.args << "\n" << r.output;
        EXPECT_NE(r.output.find(c.says), std::string::npos) << c.args << "\n" << r.output;
    }
    // Allowed to miss samples: it says how many, and merges the rest.
    const test::CliRun r = run_mcpt("merge --allow-missing " + a + out);
    EXPECT_EQ(r.status, 0) << r.output;
    EXPECT_NE(r.output.find("64 of 128 samples per pixel missing"), std::string::npos) << r.output;
    // Negative control: the two parts of one job merge.
    EXPECT_EQ(run_mcpt("merge " + a + " " + b + out).status, 0);
}

// compare --parallel: A and B at once, each on its device; the verdict as one after the other
// (a 20% brighter light in B must still be told apart).
TEST(ScaleOut, CompareRendersAAndBAtOnce) {
    const std::string dev = test::device_args("opencl");
    const std::string args = "compare cornell --a opencl:" + dev.substr(dev.rfind(' ') + 1) +
                             " --b vulkan --width 24 --height 24 --batches 12 --spp 4 --parallel";
    const test::CliRun r = run_mcpt(args);
    EXPECT_EQ(r.status, 0) << r.output;
    EXPECT_NE(r.output.find("rendered at once"), std::string::npos) << r.output;
    const test::CliRun biased = run_mcpt(args + " --b-light-scale 1.2");
    EXPECT_EQ(biased.status, 2) << biased.output;
}

// A fenced block of docs/scaling.md after its marker comment ("" if there is none).
std::string doc_block(const std::string& marker, const std::string& lang) {
    const std::string doc =
        test::read_file(std::string(MCPT_TEST_DATA_DIR) + "/../../docs/scaling.md");
    const size_t at = doc.find("<!-- " + marker + " -->");
    const size_t start = at == std::string::npos ? at : doc.find("```" + lang + "\n", at);
    const size_t end = start == std::string::npos ? start : doc.find("\n```\n", start);
    if (end == std::string::npos) return "";
    const size_t body = start + 4 + lang.size();
    return doc.substr(body, end + 1 - body);
}

// The Slurm job array and the Kubernetes Indexed Job of docs/scaling.md, taken from the page
// as written, run with the variables their schedulers set (4 parts), then merged as the page
// says: the file of one reproducible render, byte for byte.
TEST(ScaleOut, SchedulerExamplesRunAsWritten) {
    const std::string one = one_device();
    const std::string options = test::device_args("opencl") + " --width 64 --height 48 --seed 3";
    // `mcpt` on the PATH, as on a cluster's nodes.
    const fs::path bin = temp("bin");
    fs::create_directories(bin);
    fs::remove(bin / "mcpt");
    fs::create_symlink(MCPT_BINARY, bin / "mcpt");
    const std::string path = "PATH=" + bin.string() + ":$PATH ";
    // Slurm: four array tasks numbered from 10 (SLURM_ARRAY_TASK_MIN), then the merge.
    const std::string script = doc_block("slurm-array", "bash");
    ASSERT_NE(script.find("#SBATCH"), std::string::npos) << "no Slurm script in docs/scaling.md";
    const fs::path sbatch = temp("render-array.sbatch"), slurm = temp("slurm");
    { std::ofstream(sbatch) << script; }
    fs::remove_all(slurm);
    for (int task = 10; task < 14; ++task) {
        const test::CliRun r =
            test::run_command("env " + path + "SLURM_ARRAY_TASK_ID=" + std::to_string(task) +
                              " SLURM_ARRAY_TASK_MIN=10 SLURM_ARRAY_TASK_COUNT=4 bash " +
                              sbatch.string() + " cornell 512 " + slurm.string() + " " + options);
        ASSERT_EQ(r.status, 0) << r.output;
    }
    test::CliRun m = test::run_command("cd " + temp("").string() + " && env " + path +
                                       "mcpt merge slurm/part-*.ckpt -o slurm/image.exr");
    ASSERT_EQ(m.status, 0) << m.output;
    EXPECT_TRUE(test::same_bytes((slurm / "image.exr").string(), one)) << m.output;
    // Kubernetes: each Job's `sh -c` command, with the environment it declares (the test's
    // scene, samples and options), four indices, then the merge Job's.
    const std::string yaml = doc_block("k8s-job", "yaml");
    std::vector<std::string> commands;
    const std::string key = "command: [\"sh\", \"-c\", \"";
    for (size_t at = yaml.find(key); at != std::string::npos; at = yaml.find(key, at + 1)) {
        const size_t from = at + key.size();
        commands.push_back(yaml.substr(from, yaml.find("\"]", from) - from));
    }
    ASSERT_EQ(commands.size(), 2u) << yaml;
    ASSERT_NE(yaml.find("completions: 4"), std::string::npos);
    const fs::path k8s = temp("k8s");
    fs::remove_all(k8s);
    fs::create_directories(k8s);
    const std::string env = "env " + path + "PARTS=4 SCENE=cornell SPP=512 OPTIONS='" + options +
                            "' OUT=" + k8s.string() + " ";
    for (int index = 0; index < 4; ++index) {
        const test::CliRun r = test::run_command(
            env + "JOB_COMPLETION_INDEX=" + std::to_string(index) + " sh -c '" + commands[0] + "'");
        ASSERT_EQ(r.status, 0) << commands[0] << "\n" << r.output;
    }
    m = test::run_command(env + "sh -c '" + commands[1] + "'");
    ASSERT_EQ(m.status, 0) << m.output;
    EXPECT_TRUE(test::same_bytes((k8s / "image.exr").string(), one)) << m.output;
}

// compare with a side on several devices (--a opencl:D,opencl:D): each batch rendered by
// both together; A/B agreement as with one device, a 20% brighter B still told apart.
TEST(ScaleOut, CompareWithASideOnTwoDevices) {
    const std::string dev = test::device_args("opencl");
    const std::string d = dev.substr(dev.rfind(' ') + 1);
    const std::string args = "compare cornell --a opencl:" + d + ",opencl:" + d +
                             " --b vulkan --width 24 --height 24 --batches 12 --spp 4";
    const test::CliRun r = run_mcpt(args);
    EXPECT_EQ(r.status, 0) << r.output;
    EXPECT_NE(r.output.find("(+1 more)"), std::string::npos) << r.output;
    EXPECT_EQ(run_mcpt(args + " --b-light-scale 1.2").status, 2);
}

TEST(ScaleOut, DeviceListsOfASide) {
    using V = std::vector<std::string>;
    EXPECT_EQ(device_list("opencl"), V{"opencl"});
    EXPECT_EQ(device_list("opencl:0,opencl:1"), (V{"opencl:0", "opencl:1"}));
    EXPECT_EQ(device_list("vulkan:0,1,limits=phone"),
              (V{"vulkan:0,limits=phone", "vulkan:1,limits=phone"}));
    EXPECT_EQ(device_list("opencl:0,vulkan:1"), (V{"opencl:0", "vulkan:1"}));
    EXPECT_THROW(device_list("0,1"), Error);
    EXPECT_THROW(device_list("opencl:0,,opencl:1"), Error);
    EXPECT_THROW(device_list("limits=phone"), Error);
}

#if MCPT_WITH_MPI
// mpirun with `ranks` ranks of mcpt running `args` (as root in CI: Open MPI must be told).
test::CliRun mpirun(int ranks, const std::string& args, const std::string& extra = "") {
    return test::run_command(
        "env OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 "
        "OMPI_MCA_rmaps_base_oversubscribe=1 mpirun --oversubscribe " +
        extra + " -np " + std::to_string(ranks) + " " + MCPT_BINARY + " " + args);
}
#endif

// The reduction's tree for 1 to 64 ranks, binomial and flat: every rank but 0 has one parent
// below it, which lists it as a child; each child's message speaks for [child, tree_end),
// exactly the ranks below it in the tree; rank 0's children's ranges cover 1..size-1 once;
// the binomial tree is no deeper than log2(size) rounded up.
TEST(ScaleOut, ReductionTreePartitionsTheRanks) {
    using wire::tree_children, wire::tree_end, wire::tree_parent;
    for (const bool flat : {false, true})
        for (int size = 1; size <= 64; ++size) {
            SCOPED_TRACE((flat ? "flat, " : "binomial, ") + std::to_string(size) + " ranks");
            std::vector<int> parents(size_t(size), -1);
            for (int r = 0; r < size; ++r)
                for (const int c : tree_children(r, size, flat)) {
                    ASSERT_TRUE(c > r && c < size) << r << " -> " << c;
                    EXPECT_EQ(parents[size_t(c)], -1) << c << " has two parents";
                    parents[size_t(c)] = r;
                    EXPECT_EQ(tree_parent(c, flat), r) << c;
                }
            int depth_limit = 0;
            while ((1 << depth_limit) < size) ++depth_limit;
            for (int r = 1; r < size; ++r) {
                ASSERT_NE(parents[size_t(r)], -1) << r << " is in no one's children";
                int depth = 0;
                for (int a = r; a != 0; a = parents[size_t(a)]) ++depth;
                EXPECT_LE(depth, flat ? 1 : depth_limit) << r;
                // The ranks below r (r itself included) are [r, tree_end(r)).
                std::vector<int> below;
                for (int q = 1; q < size; ++q) {
                    int a = q;
                    while (a != 0 && a != r) a = parents[size_t(a)];
                    if (a == r) below.push_back(q);
                }
                const int end = tree_end(r, size, flat);
                ASSERT_EQ(int(below.size()), end - r) << r;
                for (size_t i = 0; i < below.size(); ++i) EXPECT_EQ(below[i], r + int(i)) << r;
            }
            int next = 1;
            for (const int c : tree_children(0, size, flat)) {
                EXPECT_EQ(c, next);
                next = tree_end(c, size, flat);
            }
            EXPECT_EQ(next, size);
        }
}

TEST(ScaleOut, MpiRanksWriteOneRanksFile) {
#if !MCPT_WITH_MPI
    GTEST_SKIP() << "built without MPI (libopenmpi-dev)";
#else
    const std::string one = one_device();
    // 1 to 8 ranks: trees of every shape (a rank with one child, with two, a lone leaf).
    for (const int ranks : {1, 2, 3, 5, 8}) {
        const fs::path out = temp("mpi" + std::to_string(ranks) + ".exr");
        fs::remove(out);
        const test::CliRun r = mpirun(ranks, job() + " --reproducible -o " + out.string());
        ASSERT_EQ(r.status, 0) << r.output;
        // Every rank took chunks (one rank doing all would write the same file).
        if (ranks > 1) {
            EXPECT_TRUE(test::every_device_took_chunks(r.output, ranks)) << r.output;
            EXPECT_NE(r.output.find("(rank " + std::to_string(ranks - 1) + "): "),
                      std::string::npos)
                << r.output;
        }
        EXPECT_TRUE(test::same_bytes(out.string(), one)) << ranks << " ranks\n" << r.output;
    }
    // The flat reduction (every rank to rank 0): the same file.
    const fs::path flat = temp("mpi_flat.exr");
    fs::remove(flat);
    const test::CliRun r =
        mpirun(3, job() + " --reproducible --reduction flat -o " + flat.string());
    ASSERT_EQ(r.status, 0) << r.output;
    EXPECT_TRUE(test::same_bytes(flat.string(), one)) << "flat\n" << r.output;
#endif
}

// Faults below an intermediate rank (4 ranks: 3 sends to 2, 2 and 1 to 0): rank 2 passing up
// its own sums without rank 3's is named by rank 0 (the samples handed out to ranks 2-3 are
// counted; a check of "no more than" passed it, and the image lacked rank 3's samples), and
// rank 3 killed is named.
TEST(ScaleOut, MpiFaultBelowAnIntermediateRankIsNamed) {
#if !MCPT_WITH_MPI
    GTEST_SKIP() << "built without MPI (libopenmpi-dev)";
#else
    const fs::path out = temp("mpi_subtree.exr");
    const std::string args = job(4096) + " -o " + out.string();
    const test::CliRun dropped = mpirun(4, args,
                                        "-x MCPT_MPI_FAULT_RANK=2 -x MCPT_MPI_FAULT_AFTER_ROUNDS=1 "
                                        "-x MCPT_MPI_FAULT=drop-children");
    EXPECT_NE(dropped.status, 0) << dropped.output;
    EXPECT_NE(dropped.output.find("ranks 2-3 (added up by rank 2)"), std::string::npos)
        << dropped.output;
    EXPECT_NE(dropped.output.find("were handed out"), std::string::npos) << dropped.output;
    const test::CliRun killed =
        mpirun(4, args, "-x MCPT_MPI_FAULT_RANK=3 -x MCPT_MPI_FAULT_AFTER_ROUNDS=1");
    EXPECT_NE(killed.status, 0) << killed.output;
    EXPECT_NE(killed.output.find("rank 3"), std::string::npos) << killed.output;
#endif
}

TEST(ScaleOut, MpiRankKilledIsNamedAndTheCheckpointResumesOnOtherRanks) {
#if !MCPT_WITH_MPI
    GTEST_SKIP() << "built without MPI (libopenmpi-dev)";
#else
    const std::string one = one_device(4096);
    const fs::path ckpt = temp("mpi.ckpt"), out = temp("mpi_killed.exr");
    fs::remove(ckpt), fs::remove(out);
    const std::string args = job(4096) + " --checkpoint " + ckpt.string() +
                             " --checkpoint-every 0.05 -o " + out.string();
    // Rank 2 dies (SIGKILL) when handed its first chunk after the first round (which rank 0
    // has collected and checkpointed by then).
    const test::CliRun killed =
        mpirun(3, args, "-x MCPT_MPI_FAULT_RANK=2 -x MCPT_MPI_FAULT_AFTER_ROUNDS=1");
    EXPECT_NE(killed.status, 0) << killed.output;
    EXPECT_NE(killed.output.find("rank 2"), std::string::npos) << killed.output;
    ASSERT_TRUE(fs::exists(ckpt)) << "no checkpoint before the kill\n" << killed.output;
    EXPECT_FALSE(fs::exists(out)) << "an image was written by a killed job";
    // Resumed on 2 ranks: the file of one uninterrupted render.
    const test::CliRun resumed = mpirun(2, args);
    ASSERT_EQ(resumed.status, 0) << resumed.output;
    EXPECT_NE(resumed.output.find("resumed from"), std::string::npos) << resumed.output;
    EXPECT_TRUE(test::same_bytes(out.string(), one)) << resumed.output;
#endif
}

#if MCPT_WITH_MPI
// MPMD: rank 0 runs `args0`, rank 1 `args1` (each with its own environment in `env1`).
test::CliRun mpirun_two(const std::string& args0, const std::string& args1,
                        const std::string& env1 = "") {
    return test::run_command(
        "env OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 mpirun --oversubscribe "
        "-np 1 " +
        std::string(MCPT_BINARY) + " " + args0 + " : -np 1 " + env1 + " " + MCPT_BINARY + " " +
        args1);
}
#endif

// A rank started for another job (another seed, other lighting, another scene) is refused at
// the start, naming the rank and what differs; its sums were added silently before.
TEST(ScaleOut, MpiRankOfAnotherJobIsRefused) {
#if !MCPT_WITH_MPI
    GTEST_SKIP() << "built without MPI (libopenmpi-dev)";
#else
    const std::string out = " -o " + temp("mpi_other_job.exr").string();
    struct Case {
        std::string rank1, says;
    };
    for (const Case& c : {Case{job(64, 4), "another job: seed 4 (rank 0: 3)"},
                          Case{job(64) + " --background 0.5,0.5,0.5", "another job: scene"},
                          Case{job(64) + " --max-depth 3", "another job: max_depth 3"}}) {
        const test::CliRun r = mpirun_two(job(64) + out, c.rank1 + out);
        EXPECT_NE(r.status, 0) << c.rank1 << "\n" << r.output;
        EXPECT_NE(r.output.find("rank 1 ("), std::string::npos) << r.output;
        EXPECT_NE(r.output.find(c.says), std::string::npos) << c.rank1 << "\n" << r.output;
    }
    // Control: the same job on both ranks renders.
    const test::CliRun same = mpirun_two(job(64) + out, job(64) + out);
    EXPECT_EQ(same.status, 0) << same.output;
#endif
}

// A rank that stops answering (SIGSTOP: hung, not dead) ends the job at its chunk's deadline,
// named, with the rounds before written; one that sends sums of another image size is
// refused before anything is allocated from them.
TEST(ScaleOut, MpiRankHungOrLyingIsNamedAndTheRoundsBeforeKept) {
#if !MCPT_WITH_MPI
    GTEST_SKIP() << "built without MPI (libopenmpi-dev)";
#else
    const fs::path out = temp("mpi_hung.exr");
    fs::remove(out);
    const std::string args = job(100000) + " --rank-timeout 2 -o " + out.string();
    const auto start = std::chrono::steady_clock::now();
    const test::CliRun hung = mpirun_two(
        args, args,
        "-x MCPT_MPI_FAULT_RANK=1 -x MCPT_MPI_FAULT_AFTER_ROUNDS=1 -x MCPT_MPI_FAULT=stop");
    EXPECT_NE(hung.status, 0) << hung.output;
    EXPECT_NE(hung.output.find("(rank 1)): did not deliver samples"), std::string::npos)
        << hung.output;
    EXPECT_NE(hung.output.find("hung or stopped"), std::string::npos) << hung.output;
    EXPECT_NE(hung.output.find("rendered before the failure"), std::string::npos) << hung.output;
    EXPECT_TRUE(fs::exists(out)) << hung.output;
    EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(),
              120.0);
    const test::CliRun lying = mpirun_two(
        args, args,
        "-x MCPT_MPI_FAULT_RANK=1 -x MCPT_MPI_FAULT_AFTER_ROUNDS=1 -x MCPT_MPI_FAULT=bad-size");
    EXPECT_NE(lying.status, 0) << lying.output;
    EXPECT_NE(lying.output.find("rank 1 ("), std::string::npos) << lying.output;
    EXPECT_NE(lying.output.find("do not fit the job: 65x48 pixels, the image is 64x48"),
              std::string::npos)
        << lying.output;
#endif
}

// The rmse column of a converge CSV, one value per checkpoint.
std::vector<double> csv_rmse(const fs::path& path) {
    std::ifstream in(path);
    std::vector<double> rmse;
    std::string line;
    std::getline(in, line);  // the header
    while (std::getline(in, line)) {
        // backend,"device",checkpoint,seconds,spp,rmse,...: the sixth field, past the quotes.
        const size_t quote = line.rfind('"');
        size_t at = quote == std::string::npos ? 0 : quote + 1;
        for (int field = 0; field < 4; ++field) at = line.find(',', at) + 1;
        rmse.push_back(std::stod(line.substr(at)));
    }
    return rmse;
}

// converge under mpirun: each run is one image on every rank, so its curve is one device's
// with the same seed (the ranks render that seed's samples, not samples of their own); the
// curve of another seed is told apart at the same tolerance.
TEST(ScaleOut, MpiConvergeIsOneDevicesCurve) {
#if !MCPT_WITH_MPI
    GTEST_SKIP() << "built without MPI (libopenmpi-dev)";
#else
    const auto converge = [](const std::string& name, int seed) {
        return "converge cornell " + test::device_args("opencl") +
               " --width 24 --height 16 --spp 256 --time 60 --seed " + std::to_string(seed) +
               " -o " + temp(name).string();
    };
    const test::CliRun one = run_mcpt(converge("converge_one", 5));
    ASSERT_EQ(one.status, 0) << one.output;
    const test::CliRun other = run_mcpt(converge("converge_other", 6));
    ASSERT_EQ(other.status, 0) << other.output;
    const test::CliRun ranks = mpirun(3, converge("converge_ranks", 5));
    ASSERT_EQ(ranks.status, 0) << ranks.output;
    EXPECT_NE(ranks.output.find("opencl x3 ranks"), std::string::npos) << ranks.output;
    EXPECT_TRUE(test::every_device_took_chunks(ranks.output, 3)) << ranks.output;
    const std::vector<double> a = csv_rmse(temp("converge_one.csv"));
    const std::vector<double> b = csv_rmse(temp("converge_ranks.csv"));
    const std::vector<double> c = csv_rmse(temp("converge_other.csv"));
    ASSERT_EQ(a.size(), 9u) << one.output;  // 1, 2, 4, ... 256 spp
    ASSERT_EQ(b.size(), a.size()) << ranks.output;
    ASSERT_EQ(c.size(), a.size()) << other.output;
    // Float sums added in another order: 1e-4 relative. Another seed: far more, somewhere.
    double worst_same = 0, worst_other = 0;
    for (size_t k = 0; k < a.size(); ++k) {
        worst_same = std::max(worst_same, std::abs(b[k] - a[k]) / a[k]);
        worst_other = std::max(worst_other, std::abs(c[k] - a[k]) / a[k]);
    }
    EXPECT_LT(worst_same, 1e-4) << ranks.output;
    EXPECT_GT(worst_other, 1e-4) << other.output;
#endif
}

// compare under mpirun: each side's batches go to every rank and come back as batch means; a
// batch is its seed's render wherever it is made, so the verdict's numbers are the single
// process's to the digit. The planted 2% brighter B is still told apart; a rank sending
// means of another size is refused.
TEST(ScaleOut, MpiCompareHandsBatchesToRanks) {
#if !MCPT_WITH_MPI
    GTEST_SKIP() << "built without MPI (libopenmpi-dev)";
#else
    const std::string device = test::test_opencl_device();
    const std::string cl = device.empty() ? "opencl" : "opencl:" + device;
    const std::string args = "compare cornell --width 32 --height 24 --batches 24 --a " + cl +
                             " --b " + cl;
    const auto verdict = [](const std::string& output) {
        const size_t at = output.find("statistical (");
        return at == std::string::npos ? std::string() : output.substr(at, output.find('\n', at) - at);
    };
    const test::CliRun one = run_mcpt(args);
    ASSERT_EQ(one.status, 0) << one.output;
    const test::CliRun ranks = mpirun(3, args);
    ASSERT_EQ(ranks.status, 0) << ranks.output;
    EXPECT_NE(ranks.output.find("(+2 more)"), std::string::npos) << ranks.output;
    ASSERT_FALSE(verdict(one.output).empty()) << one.output;
    EXPECT_EQ(verdict(ranks.output), verdict(one.output)) << ranks.output;
    const test::CliRun planted = mpirun(3, args + " --b-light-scale 1.02");
    EXPECT_EQ(planted.status, 2) << planted.output;
    EXPECT_NE(planted.output.find("DIFFER"), std::string::npos) << planted.output;
    // A rank whose batch means come with another image size is refused, named, at once.
    const test::CliRun lying = mpirun(
        2, args,
        "-x MCPT_MPI_FAULT_RANK=1 -x MCPT_MPI_FAULT_AFTER_ROUNDS=2 -x MCPT_MPI_FAULT=bad-size");
    EXPECT_NE(lying.status, 0) << lying.output;
    EXPECT_NE(lying.output.find("(rank 1) sent a batch that does not fit the job: 33x24 pixels"),
              std::string::npos)
        << lying.output;
    // What mpirun cannot do here is refused on every rank, with the reason.
    const test::CliRun parallel = mpirun(2, args + " --parallel");
    EXPECT_NE(parallel.status, 0);
    EXPECT_NE(parallel.output.find("not with --parallel"), std::string::npos) << parallel.output;
#endif
}

// The sample count of "wrote the N spp rendered before the failure" (0 if absent).
uint64_t spp_before_failure(const std::string& output) {
    const std::string key = "wrote the ";
    const size_t at = output.find(key);
    if (at == std::string::npos || output.find("spp rendered before the failure", at) == std::string::npos)
        return 0;
    return std::stoull(output.substr(at + key.size()));
}

TEST(ScaleOut, MpiRankWhoseDeviceIsLostIsNamedAndTheSamplesKept) {
#if !MCPT_WITH_MPI
    GTEST_SKIP() << "built without MPI (libopenmpi-dev)";
#else
    const fs::path out = temp("mpi_lost.exr");
    fs::remove(out);
    // Rank 1 alone loses its device at its 120th dispatch, a few rounds in (MPMD: its own
    // environment); the round it fails in is dropped, the rounds before are kept: the file is
    // exactly one device's reproducible render of the samples it says it holds.
    const std::string args = job(100000) + " --reproducible -o " + out.string();
    const test::CliRun r = mpirun_two(args, args, "-x MCPT_LOSE_DEVICE_AFTER=120");
    EXPECT_NE(r.status, 0) << r.output;
    EXPECT_NE(r.output.find("device 1 ("), std::string::npos) << r.output;
    EXPECT_NE(r.output.find("(rank 1)"), std::string::npos) << r.output;
    const uint64_t kept = spp_before_failure(r.output);
    ASSERT_GT(kept, 0u) << r.output;
    EXPECT_TRUE(test::same_bytes(out.string(), one_device(int(kept)))) << kept << " spp\n" << r.output;
    // Control: one granule more or less is another file.
    EXPECT_FALSE(test::same_bytes(out.string(), one_device(int(kept) - 16)));
#endif
}

}  // namespace
}  // namespace mcpt
