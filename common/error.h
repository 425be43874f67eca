// The exception types for bad input and device failures: main() prints them and exits 1.
#pragma once
#include <stdexcept>
#include <string>

namespace mcpt {
struct Error : std::runtime_error {
    explicit Error(const std::string& what) : std::runtime_error(what) {}
};
// A device that stopped in the middle of work: lost (a driver reset, or a watchdog ending a
// submission that ran too long) or out of resources while executing. Its memory is gone; a
// session keeps the samples it had read back, and never uses the device again.
struct DeviceLost : Error {
    explicit DeviceLost(const std::string& what) : Error(what) {}
};
// Not enough memory for what was asked (the C API's MCPT_ERROR_OUT_OF_MEMORY).
struct OutOfMemory : Error {
    explicit OutOfMemory(const std::string& what) : Error(what) {}
};
}  // namespace mcpt
