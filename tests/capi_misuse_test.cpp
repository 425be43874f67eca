// The C API's answers that need no device: versions, status names, and calls with NULL or
// made-up handles, or a backend this build lacks. (capi_test.cpp covers live sessions.)
#include <gtest/gtest.h>

#include <string>

#include "mcpt/mcpt.h"

TEST(CApiMisuse, Version) {
    EXPECT_EQ(mcpt_version(),
              MCPT_VERSION_MAJOR * 10000 + MCPT_VERSION_MINOR * 100 + MCPT_VERSION_PATCH);
    EXPECT_STREQ(mcpt_version_string(), MCPT_VERSION_STRING);
    EXPECT_STREQ(mcpt_status_name(MCPT_ERROR_SCENE), "MCPT_ERROR_SCENE");
    EXPECT_STREQ(mcpt_status_name(MCPT_ERROR_DEVICE_LOST), "MCPT_ERROR_DEVICE_LOST");
    EXPECT_STREQ(mcpt_status_name(mcpt_status(42)), "unknown status");
}

TEST(CApiMisuse, NullAndMadeUpHandles) {
    for (mcpt_session s : {mcpt_session(nullptr), reinterpret_cast<mcpt_session>(0x5678)}) {
        uint8_t px[4];
        EXPECT_EQ(mcpt_session_release(s), MCPT_ERROR_INVALID_HANDLE);
        EXPECT_EQ(mcpt_session_load_builtin(s, "cornell"), MCPT_ERROR_INVALID_HANDLE);
        EXPECT_EQ(mcpt_session_render(s, 1, 0, 0, nullptr), MCPT_ERROR_INVALID_HANDLE);
        EXPECT_EQ(mcpt_session_cancel(s), MCPT_ERROR_INVALID_HANDLE);
        EXPECT_EQ(mcpt_session_read_rgba8(s, px, 4), MCPT_ERROR_INVALID_HANDLE);
        EXPECT_NE(std::string(mcpt_last_error(s)).find("session handle"), std::string::npos);
    }
    mcpt_session out = nullptr;
    EXPECT_EQ(mcpt_session_create("no-such-api", &out), MCPT_ERROR_DEVICE);
    EXPECT_EQ(out, nullptr);
    EXPECT_NE(std::string(mcpt_last_error(nullptr)).find("unknown backend 'no-such-api'"),
              std::string::npos)
        << mcpt_last_error(nullptr);
    EXPECT_EQ(mcpt_session_create("", nullptr), MCPT_ERROR_INVALID_ARGUMENT);
    EXPECT_EQ(mcpt_devices(nullptr, 0, nullptr), MCPT_ERROR_INVALID_ARGUMENT);
}

// An API this build has (the arm64 build has no OpenCL).
#if MCPT_WITH_OPENCL
#define MCPT_TEST_API "opencl"
#else
#define MCPT_TEST_API "vulkan"
#endif

// Jobs (section 10) before any device is opened: bad handles, bad sides, out-of-order calls,
// a compare reading on a converge job, and a released handle.
TEST(CApiMisuse, Jobs) {
    for (mcpt_job j : {mcpt_job(nullptr), reinterpret_cast<mcpt_job>(0x5678)}) {
        mcpt_compare_result r;
        EXPECT_EQ(mcpt_job_release(j), MCPT_ERROR_INVALID_HANDLE);
        EXPECT_EQ(mcpt_job_run(j), MCPT_ERROR_INVALID_HANDLE);
        EXPECT_EQ(mcpt_job_cancel(j), MCPT_ERROR_INVALID_HANDLE);
        double f = 0;
        EXPECT_EQ(mcpt_job_progress(j, &f), MCPT_ERROR_INVALID_HANDLE);
        EXPECT_EQ(mcpt_compare_get_result(j, &r), MCPT_ERROR_INVALID_HANDLE);
        EXPECT_NE(std::string(mcpt_job_last_error(j)).find("job handle"), std::string::npos);
    }
    // A session handle is not a job, nor the reverse.
    mcpt_job out = nullptr;
    EXPECT_EQ(mcpt_compare_create(MCPT_TEST_API, "", &out), MCPT_ERROR_INVALID_ARGUMENT);
    EXPECT_EQ(out, nullptr);
    EXPECT_NE(std::string(mcpt_job_last_error(nullptr)).find("an empty device in ''"),
              std::string::npos)
        << mcpt_job_last_error(nullptr);
    EXPECT_EQ(mcpt_compare_create(MCPT_TEST_API, "metal:0", &out), MCPT_ERROR_INVALID_ARGUMENT);
    EXPECT_NE(std::string(mcpt_job_last_error(nullptr)).find("'metal:0' in 'metal:0' names no API"),
              std::string::npos)
        << mcpt_job_last_error(nullptr);
    EXPECT_EQ(mcpt_compare_create(MCPT_TEST_API, "vulkan,limits=moon", &out),
              MCPT_ERROR_INVALID_ARGUMENT);
    EXPECT_EQ(mcpt_compare_create(nullptr, MCPT_TEST_API, &out), MCPT_ERROR_INVALID_ARGUMENT);
    EXPECT_EQ(mcpt_compare_create(MCPT_TEST_API, MCPT_TEST_API, nullptr),
              MCPT_ERROR_INVALID_ARGUMENT);
    EXPECT_EQ(mcpt_converge_create(nullptr, 0, &out), MCPT_ERROR_INVALID_ARGUMENT);

    ASSERT_EQ(
        mcpt_compare_create(MCPT_TEST_API, MCPT_TEST_API ":0," MCPT_TEST_API ":0,tree=bvh", &out),
        MCPT_OK)
        << mcpt_job_last_error(nullptr);
    EXPECT_EQ(mcpt_session_release(reinterpret_cast<mcpt_session>(out)), MCPT_ERROR_INVALID_HANDLE);
    // Out of order: a result before a run, a run before a scene.
    mcpt_compare_result r;
    EXPECT_EQ(mcpt_compare_get_result(out, &r), MCPT_ERROR_INVALID_STATE);
    EXPECT_NE(std::string(mcpt_job_last_error(out)).find("has not run"), std::string::npos);
    EXPECT_EQ(mcpt_job_run(out), MCPT_ERROR_INVALID_STATE);
    EXPECT_NE(std::string(mcpt_job_last_error(out)).find("no scene"), std::string::npos);
    EXPECT_EQ(mcpt_job_write_report(out, "/tmp/x"), MCPT_ERROR_INVALID_STATE);
    EXPECT_EQ(mcpt_job_progress(out, nullptr), MCPT_ERROR_INVALID_ARGUMENT);
    // The other kind's calls.
    mcpt_converge_result cr;
    EXPECT_EQ(mcpt_converge_get_result(out, &cr), MCPT_ERROR_INVALID_ARGUMENT);
    mcpt_converge_options co;
    ASSERT_EQ(mcpt_converge_default_options(&co), MCPT_OK);
    EXPECT_EQ(mcpt_converge_set_options(out, &co), MCPT_ERROR_INVALID_ARGUMENT);
    EXPECT_NE(std::string(mcpt_job_last_error(out)).find("not a converge job"), std::string::npos);
    // Options out of range, a tree that does not exist, a scene that cannot be read.
    mcpt_compare_options o;
    ASSERT_EQ(mcpt_compare_default_options(&o), MCPT_OK);
    EXPECT_EQ(o.batches, 32);
    o.batches = 1;
    EXPECT_EQ(mcpt_compare_set_options(out, &o), MCPT_ERROR_INVALID_ARGUMENT);
    EXPECT_NE(std::string(mcpt_job_last_error(out)).find("batches"), std::string::npos);
    EXPECT_EQ(mcpt_job_set_tree(out, "octree"), MCPT_ERROR_INVALID_ARGUMENT);
    EXPECT_EQ(mcpt_job_set_size(out, 0, 64), MCPT_ERROR_INVALID_ARGUMENT);
    EXPECT_EQ(mcpt_job_load_file(out, "/no/such/scene.gltf"), MCPT_ERROR_SCENE);
    EXPECT_EQ(mcpt_compare_read_map(out, MCPT_MAP_Z, nullptr, 0), MCPT_ERROR_INVALID_STATE);
    // Released: refused, never reached.
    EXPECT_EQ(mcpt_job_release(out), MCPT_OK);
    EXPECT_EQ(mcpt_job_release(out), MCPT_ERROR_INVALID_HANDLE);
    EXPECT_EQ(mcpt_job_run(out), MCPT_ERROR_INVALID_HANDLE);

    const char* runs[] = {MCPT_TEST_API, nullptr};
    EXPECT_EQ(mcpt_converge_create(runs, 2, &out), MCPT_ERROR_INVALID_ARGUMENT);
    ASSERT_EQ(mcpt_converge_create(runs, 1, &out), MCPT_OK);
    co.seconds = 0, co.max_spp = 0;
    EXPECT_EQ(mcpt_converge_set_options(out, &co), MCPT_ERROR_INVALID_ARGUMENT);
    mcpt_converge_run run;
    EXPECT_EQ(mcpt_converge_get_run(out, 0, &run), MCPT_ERROR_INVALID_STATE);
    EXPECT_EQ(mcpt_compare_get_result(out, &r), MCPT_ERROR_INVALID_ARGUMENT);
    EXPECT_EQ(mcpt_job_release(out), MCPT_OK);
}
