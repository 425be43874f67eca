// The host's processors this process may use: what every thread pool is sized by, so that
// taskset, MPI binding, Slurm's cores and a container's CPU limit get the threads they grant.
#pragma once

namespace mcpt {

// The CPUs in this thread's affinity mask (sched_getaffinity), no more than the cgroup's CPU
// quota allows (cpu.max, rounded up; Kubernetes CPU limits); at least 1. Without either,
// std::thread::hardware_concurrency().
unsigned usable_cpus();

}  // namespace mcpt
