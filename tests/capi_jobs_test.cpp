// The C API's jobs (include/mcpt/mcpt.h section 10) on the CPU drivers: the A/B test of OpenCL
// against Vulkan agrees and a 1.02 light on one side differs (both tests), the error curve of
// the furnace falls as spp^-1/2 and 2 bounces are flagged as biased, a cancel mid-job keeps
// and reports what was done, and the reports are written.
#include <gtest/gtest.h>

#include <chrono>
#include <filesystem>
#include <string>
#include <thread>
#include <vector>

#include "mcpt/mcpt.h"
#include "test_util.h"

namespace {

std::string opencl_spec() {
    return "opencl:" + mcpt::test::test_opencl_device();
}
std::string vulkan_spec() {
    const char* e = std::getenv("MCPT_TEST_VULKAN_DEVICE");
    return e ? "vulkan:" + std::string(e) : "vulkan";
}

struct Job {
    mcpt_job j = nullptr;
    ~Job() {
        if (j) mcpt_job_release(j);
    }
    std::string error() const { return mcpt_job_last_error(j); }
};

// Waits (a minute at most) until the job's progress passes `fraction`.
bool progress_passes(mcpt_job j, double fraction) {
    const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(60);
    double f = 0;
    while (std::chrono::steady_clock::now() < until) {
        if (mcpt_job_progress(j, &f) != MCPT_OK) return false;
        if (f > fraction) return true;
        std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    return false;
}

// An A/B of the Cornell box at the command's defaults (64x64, 32 batches x 4 spp).
mcpt_compare_result compare(const std::string& a, const std::string& b, float light_scale_b) {
    Job job;
    EXPECT_EQ(mcpt_compare_create(a.c_str(), b.c_str(), &job.j), MCPT_OK)
        << mcpt_job_last_error(nullptr);
    EXPECT_EQ(mcpt_job_load_builtin(job.j, "cornell"), MCPT_OK) << job.error();
    mcpt_compare_options o;
    EXPECT_EQ(mcpt_compare_default_options(&o), MCPT_OK);
    o.light_scale_b = light_scale_b;
    EXPECT_EQ(mcpt_compare_set_options(job.j, &o), MCPT_OK) << job.error();
    double progress = -1;
    EXPECT_EQ(mcpt_job_progress(job.j, &progress), MCPT_OK);
    EXPECT_EQ(progress, 0.0);  // before a run
    EXPECT_EQ(mcpt_job_run(job.j), MCPT_OK) << job.error();
    EXPECT_EQ(mcpt_job_progress(job.j, &progress), MCPT_OK);
    EXPECT_EQ(progress, 1.0);
    mcpt_compare_result r{};
    EXPECT_EQ(mcpt_compare_get_result(job.j, &r), MCPT_OK) << job.error();
    // The maps: the p-values are probabilities, alpha 1.
    std::vector<float> map(4 * 64 * 64);
    EXPECT_EQ(mcpt_compare_read_map(job.j, MCPT_MAP_P_VALUE, map.data(), map.size()), MCPT_OK);
    for (size_t i = 0; i < map.size(); i += 4) {
        EXPECT_TRUE(map[i] >= 0.f && map[i] <= 1.f) << i;
        EXPECT_EQ(map[i + 3], 1.f);
    }
    EXPECT_EQ(mcpt_compare_read_map(job.j, MCPT_MAP_Z, map.data(), map.size() - 1),
              MCPT_ERROR_INVALID_ARGUMENT);
    return r;
}

TEST(CApiCompare, OpenClAgainstVulkanAgrees) {
    const mcpt_compare_result r = compare(opencl_spec(), vulkan_spec(), 1.f);
    EXPECT_TRUE(r.agree);
    EXPECT_TRUE(r.statistical_tested && r.statistical_agree)
        << "min p " << r.min_p << " (Sidak " << r.sidak_level << "), mean z " << r.mean_z_score;
    EXPECT_TRUE(r.same_seed_tested && r.same_seed_agree);
    // Rounding alone: within the command's same-seed limit (1 % of the pixels).
    EXPECT_LE(double(r.same_seed_diverged), 0.01 * double(r.same_seed_pixels));
    EXPECT_EQ(r.same_seed_pixels, 64u * 64u);
    EXPECT_FALSE(r.cancelled);
    for (const mcpt_compare_side& s : r.side) {
        EXPECT_EQ(s.batches_done, 32);
        EXPECT_GT(s.samples_per_second, 0);
        EXPECT_EQ(s.devices, 1);
        EXPECT_NE(std::string(s.device), "");
    }
    EXPECT_NE(std::string(r.side[0].device).find("opencl"), std::string::npos) << r.side[0].device;
    EXPECT_NE(std::string(r.side[1].device).find("vulkan"), std::string::npos) << r.side[1].device;
    EXPECT_GT(r.speed_ratio, 0);
}

// The negative control: B's light 2 % brighter is told apart by both tests.
TEST(CApiCompare, LightTwoPercentBrighterDiffers) {
    const mcpt_compare_result r = compare(opencl_spec(), vulkan_spec(), 1.02f);
    EXPECT_FALSE(r.agree);
    EXPECT_TRUE(r.statistical_tested);
    EXPECT_FALSE(r.statistical_agree) << "mean z " << r.mean_z_score;
    EXPECT_GT(r.mean_relative_diff, 0.01);
    EXPECT_FALSE(r.same_seed_agree);
    EXPECT_GT(double(r.same_seed_diverged), 0.5 * double(r.same_seed_pixels));
}

// Cancelled mid-job: the batches done are kept and reported; a side without two batches has
// no statistical test, and the job does not agree.
TEST(CApiCompare, CancelKeepsWhatWasDone) {
    Job job;
    ASSERT_EQ(mcpt_compare_create(opencl_spec().c_str(), opencl_spec().c_str(), &job.j), MCPT_OK);
    ASSERT_EQ(mcpt_job_load_builtin(job.j, "cornell"), MCPT_OK);
    mcpt_compare_options o;
    ASSERT_EQ(mcpt_compare_default_options(&o), MCPT_OK);
    o.batches = 100000;
    ASSERT_EQ(mcpt_compare_set_options(job.j, &o), MCPT_OK);
    mcpt_status st = MCPT_OK;
    std::thread run([&] { st = mcpt_job_run(job.j); });
    // Once A has rendered three batches (progress counts both sides' 200,000).
    EXPECT_TRUE(progress_passes(job.j, 2.5 / 200000)) << "no batch within a minute";
    EXPECT_EQ(mcpt_job_cancel(job.j), MCPT_OK);
    run.join();
    EXPECT_EQ(st, MCPT_CANCELLED) << job.error();
    mcpt_compare_result r{};
    ASSERT_EQ(mcpt_compare_get_result(job.j, &r), MCPT_OK) << job.error();
    EXPECT_TRUE(r.cancelled);
    EXPECT_GE(r.side[0].batches_done, 3);
    EXPECT_LT(r.side[0].batches_done, 100000);
    EXPECT_EQ(r.side[1].batches_done, 0);  // A's batches come first
    EXPECT_FALSE(r.statistical_tested);
    EXPECT_FALSE(r.agree);
    // A run after the cancel is not affected by it.
    o.batches = 4;
    ASSERT_EQ(mcpt_compare_set_options(job.j, &o), MCPT_OK);
    ASSERT_EQ(mcpt_job_run(job.j), MCPT_OK) << job.error();
    ASSERT_EQ(mcpt_compare_get_result(job.j, &r), MCPT_OK);
    EXPECT_EQ(r.side[1].batches_done, 4);
    EXPECT_FALSE(r.cancelled);
}

// The furnace's error curve through the C API: each run's fitted slope near -1/2 with
// independent samples, exact reference; with 2 bounces (radiance 1.75 against 2) BIASED.
mcpt_converge_result converge(int bounces, Job& job) {
    const std::string runs[2] = {opencl_spec(), vulkan_spec()};
    const char* specs[2] = {runs[0].c_str(), runs[1].c_str()};
    EXPECT_EQ(mcpt_converge_create(specs, 2, &job.j), MCPT_OK) << mcpt_job_last_error(nullptr);
    EXPECT_EQ(mcpt_job_load_builtin(job.j, "furnace"), MCPT_OK) << job.error();
    EXPECT_EQ(mcpt_job_set_size(job.j, 32, 32), MCPT_OK);
    EXPECT_EQ(mcpt_job_set_max_bounces(job.j, bounces), MCPT_OK);
    mcpt_converge_options o;
    EXPECT_EQ(mcpt_converge_default_options(&o), MCPT_OK);
    o.seconds = 0, o.max_spp = 256, o.independent = 1, o.seed = 11;
    EXPECT_EQ(mcpt_converge_set_options(job.j, &o), MCPT_OK) << job.error();
    EXPECT_EQ(mcpt_job_run(job.j), MCPT_OK) << job.error();
    mcpt_converge_result r{};
    EXPECT_EQ(mcpt_converge_get_result(job.j, &r), MCPT_OK) << job.error();
    return r;
}

TEST(CApiConverge, FurnaceFallsAsSppToTheMinusHalf) {
    Job job;
    const mcpt_converge_result r = converge(-1, job);
    ASSERT_EQ(r.runs, 2u);
    EXPECT_FALSE(r.biased);
    EXPECT_TRUE(r.reference_exact);
    EXPECT_DOUBLE_EQ(r.reference_mean, 2.0);
    for (uint64_t k = 0; k < r.runs; ++k) {
        mcpt_converge_run run{};
        ASSERT_EQ(mcpt_converge_get_run(job.j, k, &run), MCPT_OK) << job.error();
        EXPECT_EQ(run.checkpoints, 9u);  // 1, 2, 4, ..., 256 spp
        // 32x32 uniform pixels over 1..256 spp: slope_sigma is a few thousandths.
        EXPECT_NEAR(run.spp_slope, -0.5, 0.08) << run.backend;
        EXPECT_FALSE(run.biased) << run.backend;
        mcpt_checkpoint last{};
        ASSERT_EQ(mcpt_converge_get_checkpoint(job.j, k, run.checkpoints - 1, &last), MCPT_OK);
        EXPECT_EQ(last.spp, 256u);
        EXPECT_EQ(last.reference_noise, 0);
        double seconds = -1;
        int how = -1;
        ASSERT_EQ(mcpt_converge_time_to_error(job.j, k, 0.10, &seconds, &how), MCPT_OK);
        EXPECT_TRUE(how == 1 || how == 3) << how;  // 10 % is reached within 256 spp
        EXPECT_GT(seconds, 0);
    }
    EXPECT_EQ(mcpt_converge_get_run(job.j, 0, nullptr), MCPT_ERROR_INVALID_ARGUMENT);
    mcpt_checkpoint c;
    EXPECT_EQ(mcpt_converge_get_checkpoint(job.j, 0, 9, &c), MCPT_ERROR_INVALID_ARGUMENT);
    // The report, as `mcpt converge --report` writes it.
    const auto dir = std::filesystem::temp_directory_path() / "mcpt_capi_converge_report";
    std::filesystem::remove_all(dir);
    ASSERT_EQ(mcpt_job_write_report(job.j, dir.string().c_str()), MCPT_OK) << job.error();
    EXPECT_TRUE(std::filesystem::exists(dir / "index.html"));
}

// The negative control: 2 bounces converge to 1.75, not the exact 2.
TEST(CApiConverge, TwoBouncesAreBiased) {
    Job job;
    const mcpt_converge_result r = converge(2, job);
    ASSERT_EQ(r.runs, 2u);
    EXPECT_TRUE(r.biased);
    mcpt_converge_run run{};
    ASSERT_EQ(mcpt_converge_get_run(job.j, 0, &run), MCPT_OK);
    EXPECT_TRUE(run.biased);
    EXPECT_NEAR(run.relative_bias, -0.125, 0.02);  // (1.75 - 2) / 2
}

// Cancelled mid-curve: the run under way ends at a last checkpoint, kept and fitted; the next
// run never starts.
TEST(CApiConverge, CancelKeepsTheCheckpointsSoFar) {
    Job job;
    const std::string spec = opencl_spec();
    const char* specs[2] = {spec.c_str(), spec.c_str()};
    ASSERT_EQ(mcpt_converge_create(specs, 2, &job.j), MCPT_OK);
    ASSERT_EQ(mcpt_job_load_builtin(job.j, "furnace"), MCPT_OK);
    ASSERT_EQ(mcpt_job_set_size(job.j, 32, 32), MCPT_OK);
    mcpt_converge_options o;
    ASSERT_EQ(mcpt_converge_default_options(&o), MCPT_OK);
    o.seconds = 600;
    ASSERT_EQ(mcpt_converge_set_options(job.j, &o), MCPT_OK);
    mcpt_status st = MCPT_OK;
    const auto start = std::chrono::steady_clock::now();
    std::thread run([&] { st = mcpt_job_run(job.j); });
    // Once the first run has a checkpoint (progress: its time against the 600 s budget).
    EXPECT_TRUE(progress_passes(job.j, 0)) << "no checkpoint within a minute";
    EXPECT_EQ(mcpt_job_cancel(job.j), MCPT_OK);
    run.join();
    EXPECT_LT(std::chrono::steady_clock::now() - start, std::chrono::seconds(60));
    EXPECT_EQ(st, MCPT_CANCELLED) << job.error();
    mcpt_converge_result r{};
    ASSERT_EQ(mcpt_converge_get_result(job.j, &r), MCPT_OK) << job.error();
    EXPECT_TRUE(r.cancelled);
    ASSERT_EQ(r.runs, 1u);
    mcpt_converge_run one{};
    ASSERT_EQ(mcpt_converge_get_run(job.j, 0, &one), MCPT_OK);
    EXPECT_GE(one.checkpoints, 1u);
    double progress = 0;
    EXPECT_EQ(mcpt_job_progress(job.j, &progress), MCPT_OK);
    EXPECT_LE(progress, 0.5);  // the first of two runs ended (cancelled), the second never began
}

}  // namespace
