// mcpt bench --specialize: full kernel against builds for each scene's features.
#pragma once
#include <cstdint>
#include <string>
#include <vector>

namespace mcpt {

struct SpecializeBenchArgs {
    std::vector<std::string> backends;  // empty: every device found
    std::string models = "models";
    std::string output = "bench-specialize";
    int width = 256, height = 256;
    uint64_t spp = 4;
    int frames = 3;
};

void run_specialize_bench(const SpecializeBenchArgs& args);

}  // namespace mcpt
