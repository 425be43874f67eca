// Fuzz target: environment map files (.exr through OpenEXR or tinyexr, Radiance .hdr through
// the RLE check and stb_image), read from memory as the C API and `--env` read them: a clear
// mcpt::Error or a well-formed map of finite, non-negative texels; never a hang (a zero-length
// RLE dump looped forever in stb_image 2.27), a crash or an unbounded allocation.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>

#include "common/error.h"
#include "common/scene/environment.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    try {
        const mcpt::Environment env = mcpt::load_environment_memory(data, size, "fuzz");
        if (env.width < 1 || env.height < 1 ||
            env.rgb.size() != size_t(env.width) * size_t(env.height) * 3)
            std::abort();
        for (float v : env.rgb)
            if (!std::isfinite(v) || v < 0.f) std::abort();
    } catch (const mcpt::Error&) {
    }
    return 0;
}
