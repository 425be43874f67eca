// mcpt bench --throughput: long renders per scene and backend, rays/s, the Vulkan/OpenCL
// ratio, work and bytes per ray.
#pragma once
#include <string>
#include <vector>

namespace mcpt {

struct ThroughputBenchArgs {
    std::vector<std::string> backends;  // empty: every device found
    std::string models = "models";
    std::string output = "bench-throughput";
    int width = 1024, height = 1024;
    double seconds = 5;         // timed, per scene and backend
    double warmup_seconds = 1;  // untimed, before it
    bool quick = false;         // the Cornell box and a small generated mesh
    std::string tree = "auto";  // auto (per device), sah, median, none or bvh; a comma list: each
    // Rows of one image on several devices: for each API and kind of device (GPUs, CPUs), its
    // first N devices of those given (or found), for every N here; empty: a row per device.
    std::vector<int> device_counts;
    // Rows for each count of node steps the BVH walk pauses after (MCPT_WALK_STEPS,
    // integrator.h: step_slot_walk); empty: the device's choice.
    std::vector<int> walk_steps;
};

void run_throughput_bench(const ThroughputBenchArgs& args);

}  // namespace mcpt
