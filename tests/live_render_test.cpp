// The live A/B view's meeting points (common/view/live_render.h): one sequence of sample
// counts, reached from any count a side's step may end at. A step that runs out of time short
// of its milestone (a CPU side at 256 x 256) must aim at the same milestone again; grown from
// where it stood, it left the sequence and never met the other side again (seen on an H100
// against PoCL: the maps stopped at 76 spp while B went on to 1,221).
#include "common/view/live_render.h"

#include <gtest/gtest.h>

#include <set>

namespace mcpt {
namespace {

TEST(LiveMilestones, OneSequenceFromAnyCount) {
    std::set<uint64_t> sequence;
    for (uint64_t m = next_milestone(0); m < 2000000; m = next_milestone(m)) {
        EXPECT_EQ(m % 4, 0u) << m;
        sequence.insert(m);
    }
    EXPECT_EQ(*sequence.begin(), 4u);
    EXPECT_GT(sequence.size(), 40u);
    for (uint64_t spp = 0; spp < 1000000; spp += spp < 4096 ? 1 : 97) {
        const uint64_t m = next_milestone(spp);
        ASSERT_GT(m, spp);
        ASSERT_EQ(sequence.count(m), 1u) << "from " << spp << ": " << m << " is off the sequence";
        // The first one above: nothing of the sequence between.
        const auto it = sequence.upper_bound(spp);
        ASSERT_EQ(*it, m) << "from " << spp;
    }
    // Growing by about a quarter: a meeting at least every 25% more samples.
    for (auto it = sequence.begin(); std::next(it) != sequence.end(); ++it) {
        if (*it < 64) continue;
        EXPECT_LE(double(*std::next(it)) / double(*it), 1.3) << *it;
    }
}

}  // namespace
}  // namespace mcpt
