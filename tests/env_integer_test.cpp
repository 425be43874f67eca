// env_integer (common/env_integer.h): the environment's measurement settings read as integers
// in a range, and refused in one wording otherwise.
#include "common/env_integer.h"

#include <gtest/gtest.h>

#include "common/render/prepare.h"

#include "test_util.h"

namespace mcpt {
namespace {

std::string refusal(long lo, long hi, const std::string& range = "") {
    try {
        env_integer("MCPT_TEST_ENV_INTEGER", lo, hi, range);
    } catch (const Error& e) {
        return e.what();
    }
    return "";
}

TEST(EnvInteger, InRangeUnsetOrRefused) {
    {
        const test::ScopedEnv unset("MCPT_TEST_ENV_INTEGER", nullptr);
        EXPECT_FALSE(env_integer("MCPT_TEST_ENV_INTEGER", 1, 32).has_value());
    }
    {
        const test::ScopedEnv v("MCPT_TEST_ENV_INTEGER", "32");
        EXPECT_EQ(env_integer("MCPT_TEST_ENV_INTEGER", 1, 32), 32);
        EXPECT_EQ(refusal(1, 31), "MCPT_TEST_ENV_INTEGER must be 1 to 31, not '32'");
        EXPECT_EQ(refusal(0, 1), "MCPT_TEST_ENV_INTEGER must be 0 or 1, not '32'");
        EXPECT_EQ(refusal(0, 8, "0 or a power of two"),
                  "MCPT_TEST_ENV_INTEGER must be 0 or a power of two, not '32'");
    }
    // Not a whole number: refused, never read as its leading digits (atoi took "3x" as 3).
    for (const char* bad : {"", "3x", " ", "x3", "1.5"}) {
        const test::ScopedEnv v("MCPT_TEST_ENV_INTEGER", bad);
        EXPECT_NE(refusal(0, 32), "") << "'" << bad << "'";
    }
}

// The BVH's collapse through tree_options(): SAH-optimal unless the variable says 0; other
// values refused.
TEST(EnvInteger, BvhCollapseSetting) {
    {
        const test::ScopedEnv unset("MCPT_BVH_COLLAPSE", nullptr);
        EXPECT_TRUE(tree_options("bvh").bvh_optimal_collapse);
    }
    {
        const test::ScopedEnv off("MCPT_BVH_COLLAPSE", "0");
        EXPECT_FALSE(tree_options("bvh").bvh_optimal_collapse);
    }
    const test::ScopedEnv bad("MCPT_BVH_COLLAPSE", "2");
    try {
        tree_options("bvh");
        ADD_FAILURE() << "MCPT_BVH_COLLAPSE=2 was taken";
    } catch (const Error& e) {
        EXPECT_EQ(std::string(e.what()),
                  "MCPT_BVH_COLLAPSE must be 0 (largest child first) or 1 (SAH-optimal), not '2'");
    }
}

}  // namespace
}  // namespace mcpt
