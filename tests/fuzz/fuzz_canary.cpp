// Negative control of the fuzzing job: a target with a planted heap overflow behind a
// four-byte key. scripts/test-fuzz requires libFuzzer to find it within seconds and the
// sanitizer to report it, proving that the targets are instrumented and a crash fails the job.
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <vector>

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    if (size >= 4 && std::memcmp(data, "mcpt", 4) == 0) {
        std::vector<uint8_t> copy(data, data + 4);
        volatile uint8_t past_the_end = copy.data()[copy.size()];  // one beyond the copy
        (void)past_the_end;
    }
    return 0;
}
