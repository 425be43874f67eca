// Thread pools sized by the CPUs the process may use (its affinity mask), not the machine's:
// under taskset, MPI binding or Slurm a build takes the cores it was granted.
#include "common/io/host_cpus.h"

#include <gtest/gtest.h>
#include <sched.h>

#include <thread>
#include <vector>

#include "common/accel/kdtree.h"

namespace mcpt {
namespace {

// Runs f with this thread bound to the first `count` CPUs of its mask, then restores it.
template <typename F>
void with_cpus(unsigned count, F f) {
    cpu_set_t all, some;
    ASSERT_EQ(sched_getaffinity(0, sizeof all, &all), 0);
    CPU_ZERO(&some);
    for (int c = 0, taken = 0; c < CPU_SETSIZE && unsigned(taken) < count; ++c)
        if (CPU_ISSET(c, &all)) CPU_SET(c, &some), ++taken;
    ASSERT_EQ(sched_setaffinity(0, sizeof some, &some), 0);
    f();
    ASSERT_EQ(sched_setaffinity(0, sizeof all, &all), 0);
}

std::vector<Triangle> stairs(int n) {
    std::vector<Triangle> t(static_cast<size_t>(n));
    for (int i = 0; i < n; ++i) {
        const float x = float(i);
        t[size_t(i)].v0 = {x, 0, 0}, t[size_t(i)].v1 = {x + 1, 0, 0}, t[size_t(i)].v2 = {x, 1, x};
    }
    return t;
}

TEST(HostCpus, FollowTheAffinityMask) {
    cpu_set_t all;
    ASSERT_EQ(sched_getaffinity(0, sizeof all, &all), 0);
    const unsigned granted = unsigned(CPU_COUNT(&all));
    EXPECT_LE(usable_cpus(), granted);
    with_cpus(1, [] { EXPECT_EQ(usable_cpus(), 1u); });
    if (granted >= 2) with_cpus(2, [] { EXPECT_EQ(usable_cpus(), 2u); });
}

// The k-d build on one granted CPU takes one thread (it took one per core of the machine).
TEST(HostCpus, TreeBuildTakesTheGrantedCpus) {
    TreeOptions o;
    o.kind = TreeKind::Sah;
    with_cpus(1, [&] { EXPECT_EQ(build_kdtree(stairs(2000), o).stats.threads, 1); });
    const KdTree free = build_kdtree(stairs(2000), o);
    EXPECT_EQ(free.stats.threads, int(usable_cpus()));
    o.threads = 3;  // asked for: taken as asked
    with_cpus(1, [&] { EXPECT_EQ(build_kdtree(stairs(2000), o).stats.threads, 3); });
}

}  // namespace
}  // namespace mcpt
