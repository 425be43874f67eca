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
