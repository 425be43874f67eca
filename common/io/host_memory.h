// The host's memory: how much is available, and sizes in words for messages. What loaders and
// the render loop check before they allocate.
#pragma once
#include <cstdint>
#include <string>

namespace mcpt {

// MemAvailable (Linux, Android), else the physical memory.
uint64_t host_memory_available();

// "1.5 GiB", "12 MiB", "256 B" (three significant digits).
std::string human_bytes(uint64_t bytes);

}  // namespace mcpt
