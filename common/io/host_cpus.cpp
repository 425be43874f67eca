#include "common/io/host_cpus.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>

#if defined(__linux__)
#include <sched.h>
#endif

namespace mcpt {

namespace {

#if defined(__linux__)
// CPUs in the affinity mask; 0 if it cannot be read. The mask is sized for up to 64k CPUs.
unsigned affinity_cpus() {
    constexpr int kMaxCpus = 1 << 16;
    cpu_set_t* set = CPU_ALLOC(kMaxCpus);
    if (!set) return 0;
    const size_t bytes = CPU_ALLOC_SIZE(kMaxCpus);
    CPU_ZERO_S(bytes, set);
    const unsigned n =
        sched_getaffinity(0, bytes, set) == 0 ? unsigned(CPU_COUNT_S(bytes, set)) : 0;
    CPU_FREE(set);
    return n;
}

// cgroup v2's "quota period" (cpu.max) of this process's group, as CPUs rounded up; 0 when
// there is none ("max") or it cannot be read.
unsigned quota_cpus() {
    std::string group;
    {
        std::ifstream cgroup("/proc/self/cgroup");
        for (std::string line; std::getline(cgroup, line);)
            if (line.rfind("0::", 0) == 0) group = line.substr(3);
    }
    for (const std::string& dir : {"/sys/fs/cgroup" + group, std::string("/sys/fs/cgroup")}) {
        std::ifstream f(dir + "/cpu.max");
        std::string text;
        if (std::getline(f, text)) return cpus_of_cpu_max(text);
    }
    return 0;
}
#endif

}  // namespace

unsigned cpus_of_cpu_max(const std::string& text) {
    std::istringstream in(text);
    std::string quota, period_text, rest;
    if (!(in >> quota >> period_text) || (in >> rest) || quota == "max") return 0;
    try {
        size_t used_q = 0, used_p = 0;
        const double q = std::stod(quota, &used_q), period = std::stod(period_text, &used_p);
        if (used_q != quota.size() || used_p != period_text.size()) return 0;
        if (!(q > 0) || !(period > 0) || !std::isfinite(q / period)) return 0;
        const double cpus = std::ceil(q / period);
        return cpus >= 65536.0 ? 65536u : unsigned(std::max(1.0, cpus));
    } catch (const std::exception&) {  // out of range
        return 0;
    }
}

unsigned usable_cpus() {
    unsigned n = std::thread::hardware_concurrency();
#if defined(__linux__)
    if (const unsigned a = affinity_cpus()) n = a;
    if (const unsigned q = quota_cpus()) n = std::min(n == 0 ? q : n, q);
#endif
    return std::max(1u, n);
}

}  // namespace mcpt
