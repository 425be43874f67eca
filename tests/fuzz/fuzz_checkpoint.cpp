// Fuzz target: checkpoint files (render --checkpoint, render --part, mcpt merge), read from
// memory: a clear mcpt::Error or sums of exactly the size the header gives; never a read or
// an allocation beyond what the bytes hold.
#include <cstddef>
#include <cstdint>
#include <cstdlib>

#include "common/error.h"
#include "common/render/checkpoint.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    try {
        mcpt::Fingerprint f;
        const mcpt::RenderResult r = mcpt::read_checkpoint_memory(data, size, f);
        const size_t n = size_t(r.width) * size_t(r.height);
        if (n == 0 || r.sum.size() != 3 * n || r.sum_sq.size() != 3 * n ||
            r.nonfinite.size() != n || (!r.exact.empty() && r.exact.size() != 6 * n))
            std::abort();
    } catch (const mcpt::Error&) {
    }
    return 0;
}
