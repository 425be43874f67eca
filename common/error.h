// The one exception type for bad input and device failures: main() prints it and exits 1.
#pragma once
#include <stdexcept>
#include <string>

namespace mcpt {
struct Error : std::runtime_error {
    explicit Error(const std::string& what) : std::runtime_error(what) {}
};
}  // namespace mcpt
