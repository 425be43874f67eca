// The host's processors this process may use: what every thread pool is sized by, so that
// taskset, MPI binding, Slurm's cores and a container's CPU limit get the threads they grant.
#pragma once
#include <algorithm>
#include <cstddef>
#include <cstring>
#include <string>
#include <thread>
#include <vector>

namespace mcpt {

// The CPUs in this thread's affinity mask (sched_getaffinity), no more than the cgroup's CPU
// quota allows (cpu.max, rounded up; Kubernetes CPU limits); at least 1. Without either,
// std::thread::hardware_concurrency().
unsigned usable_cpus();

// The CPUs a cgroup v2 `cpu.max` ("QUOTA PERIOD", microseconds) grants, rounded up, at
// least 1; 0 when it grants no limit ("max") or the text is not that ("150000 100000" -> 2).
unsigned cpus_of_cpu_max(const std::string& text);

// Runs fn(begin, end) over [0, n) in ranges of at least `grain` items, on threads of their
// own (at most usable_cpus()), the calling thread taking the first: an image's sums (a
// gigabyte at 4096x4096) are added and converted at the memory's speed, not one core's.
template <typename Fn>
void for_ranges(size_t n, const Fn& fn, size_t grain = size_t(1) << 16) {
    const size_t parts = std::clamp<size_t>(n / std::max<size_t>(grain, 1), 1, usable_cpus());
    std::vector<std::thread> threads;
    for (size_t t = 1; t < parts; ++t) threads.emplace_back(fn, n * t / parts, n * (t + 1) / parts);
    fn(size_t(0), n / parts);
    for (std::thread& t : threads) t.join();
}

// memcpy over threads (for_ranges): a read-back's copy out of staging memory at the memory's
// speed, not one core's.
inline void copy_on_threads(void* to, const void* from, size_t bytes) {
    for_ranges(
        bytes,
        [&](size_t begin, size_t end) {
            std::memcpy(static_cast<char*>(to) + begin, static_cast<const char*>(from) + begin,
                        end - begin);
        },
        size_t(1) << 22);
}

}  // namespace mcpt
