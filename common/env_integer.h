// Measurement and test settings read from the environment (MCPT_WALK_STEPS,
// MCPT_NV_MAXRREGCOUNT, MCPT_VULKAN_WORKGROUP, ...): an integer in a range, and one refusal,
// "NAME must be LO to HI, not 'VALUE'", for anything else (mcpt::Error: main() exits 1).
#pragma once
#include <cstdlib>
#include <optional>
#include <string>

#include "common/error.h"

namespace mcpt {

// The refusal of $name's value; `range` says what it may be.
[[noreturn]] inline void refuse_env(const char* name, const std::string& range) {
    const char* e = std::getenv(name);
    throw Error(std::string(name) + " must be " + range + ", not '" + (e ? e : "") + "'");
}

// $name as an integer in [lo, hi], nullopt where it is unset; anything else (empty, not a
// number, out of range) refused, in the words of `range` if given, else "lo to hi" ("lo or hi"
// where those are all).
inline std::optional<long> env_integer(const char* name, long lo, long hi,
                                       const std::string& range = "") {
    const char* e = std::getenv(name);
    if (!e) return std::nullopt;
    char* end = nullptr;
    const long n = std::strtol(e, &end, 10);
    if (*e == '\0' || *end != '\0' || n < lo || n > hi)
        refuse_env(name, !range.empty() ? range
                                        : std::to_string(lo) + (hi == lo + 1 ? " or " : " to ") +
                                              std::to_string(hi));
    return n;
}

}  // namespace mcpt
