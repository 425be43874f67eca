// Fuzz target: the image files mcpt writes and reads. Input byte 0 picks the case:
//  even: the bytes are an EXR file, read as `compare` and the tests read references (any
//        file a user hands over): a clear mcpt::Error or a well-formed image;
//  odd:  the bytes are a width, a height and float pixels (NaN, Inf, denormals included),
//        written as EXR and PNG; the EXR must read back bit for bit.
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include "common/error.h"
#include "common/io/image_io.h"

namespace {

// A file of this process's own in the temporary folder.
std::string scratch(const char* ext) {
    const char* dir = std::getenv("TMPDIR");
    return std::string(dir && *dir ? dir : "/tmp") + "/mcpt_fuzz_image_" +
           std::to_string(getpid()) + ext;
}

void read_case(const uint8_t* data, size_t size) {
    const std::string path = scratch(".exr");
    FILE* f = std::fopen(path.c_str(), "wb");
    if (!f) std::abort();
    if (size > 0 && std::fwrite(data, 1, size, f) != size) std::abort();
    std::fclose(f);
    try {
        int w = -1, h = -1;
        const std::vector<float> rgb = mcpt::read_exr(path, w, h);
        if (w <= 0 || h <= 0 || rgb.size() != size_t(w) * size_t(h) * 3) std::abort();
    } catch (const mcpt::Error&) {
    }
    std::remove(path.c_str());
}

void write_case(const uint8_t* data, size_t size) {
    if (size < 2) return;
    const int width = 1 + data[0] % 64, height = 1 + data[1] % 64;
    data += 2, size -= 2;
    std::vector<float> rgb(size_t(width) * height * 3, 0.f);
    std::memcpy(rgb.data(), data, std::min(size, rgb.size() * sizeof(float)));
    const std::string exr = scratch(".exr"), png = scratch(".png");
    mcpt::write_image(exr, width, height, rgb);
    mcpt::write_image(png, width, height, rgb);
    int w = 0, h = 0;
    const std::vector<float> back = mcpt::read_exr(exr, w, h);
    if (w != width || h != height || back.size() != rgb.size() ||
        std::memcmp(back.data(), rgb.data(), rgb.size() * sizeof(float)) != 0) {
        std::fprintf(stderr, "EXR round trip changed the image (%dx%d)\n", width, height);
        std::abort();
    }
    std::remove(exr.c_str());
    std::remove(png.c_str());
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    if (size == 0) return 0;
    if (data[0] & 1u)
        write_case(data + 1, size - 1);
    else
        read_case(data + 1, size - 1);
    return 0;
}
