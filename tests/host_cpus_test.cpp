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

// cgroup v2's cpu.max as a container runtime writes it (Kubernetes' CPU limit: 1.5 CPUs is
// "150000 100000"): rounded up, at least one, nothing for "max" or anything else.
TEST(HostCpus, CpuMaxIsParsedAsTheKernelWritesIt) {
    EXPECT_EQ(cpus_of_cpu_max("150000 100000"), 2u);
    EXPECT_EQ(cpus_of_cpu_max("150000 100000\n"), 2u);
    EXPECT_EQ(cpus_of_cpu_max("200000 100000"), 2u);
    EXPECT_EQ(cpus_of_cpu_max("50000 100000"), 1u);
    EXPECT_EQ(cpus_of_cpu_max("1000 100000"), 1u);
    EXPECT_EQ(cpus_of_cpu_max("800000 50000"), 16u);
    EXPECT_EQ(cpus_of_cpu_max("max 100000"), 0u);
    for (const char* garbage : {"", "max", "150000", "abc 100000", "150000 abc", "150000x 100000",
                                "-150000 100000", "150000 0", "150000 -1", "0 100000", "nan 100000",
                                "inf 100000", "1e999 100000", "150000 100000 7"})
        EXPECT_EQ(cpus_of_cpu_max(garbage), 0u) << '"' << garbage << '"';
    EXPECT_EQ(cpus_of_cpu_max("1e300 1"), 65536u);  // no overflow into a small count
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
