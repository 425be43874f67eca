#include "common/scene/environment.h"

#include <stb_image.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <vector>

#include "common/error.h"
#include "common/io/image_io.h"

namespace mcpt {

namespace {

// Checks the texels (finite; negatives clamped to 0) and the size.
Environment checked(std::vector<float> rgb, int width, int height, const std::string& name) {
    if (width < 1 || height < 1 || width > kMaxEnvironmentWidth ||
        height > kMaxEnvironmentWidth / 2)
        throw Error("environment map " + name + ": " + std::to_string(width) + "x" +
                    std::to_string(height) + " texels, outside 1x1 to 16384x8192");
    size_t nonfinite = 0;
    for (float& v : rgb) {
        if (!std::isfinite(v)) ++nonfinite;
        if (v < 0.f) v = 0.f;
    }
    if (nonfinite > 0)
        throw Error("environment map " + name + ": " + std::to_string(nonfinite) +
                    " non-finite texel values (NaN or Inf)");
    Environment env;
    env.name = name;
    env.width = width, env.height = height;
    env.rgb = std::move(rgb);
    return env;
}

bool starts_with(const unsigned char* data, size_t size, const char* magic) {
    const size_t n = std::strlen(magic);
    return size >= n && std::memcmp(data, magic, n) == 0;
}

}  // namespace

Environment load_environment_memory(const unsigned char* data, size_t size,
                                    const std::string& name) {
    static const unsigned char kExrMagic[4] = {0x76, 0x2f, 0x31, 0x01};
    if (!data || size == 0) throw Error("environment map " + name + ": no data");
    if (size >= 4 && std::memcmp(data, kExrMagic, 4) == 0) {
        int w = 0, h = 0;
        std::vector<float> rgb = read_exr_memory(data, size, name, w, h);
        return checked(std::move(rgb), w, h, name);
    }
    if (starts_with(data, size, "#?RADIANCE") || starts_with(data, size, "#?RGBE")) {
        if (size > size_t(INT32_MAX))
            throw Error("environment map " + name + ": over 2 GiB");
        int w = 0, h = 0, channels = 0;
        // The size first, so that nothing larger than the limit is decoded.
        if (!stbi_info_from_memory(data, int(size), &w, &h, &channels))
            throw Error("environment map " + name + ": " + stbi_failure_reason());
        if (w < 1 || h < 1 || w > kMaxEnvironmentWidth || h > kMaxEnvironmentWidth / 2)
            return checked({}, w, h, name);  // throws the size error
        float* px = stbi_loadf_from_memory(data, int(size), &w, &h, &channels, 3);
        if (!px) throw Error("environment map " + name + ": " + stbi_failure_reason());
        std::vector<float> rgb(px, px + size_t(w) * size_t(h) * 3);
        stbi_image_free(px);
        return checked(std::move(rgb), w, h, name);
    }
    throw Error("environment map " + name +
                ": not an OpenEXR or Radiance .hdr file (equirectangular, linear)");
}

Environment load_environment(const std::string& path) {
    std::error_code ec;
    const auto size = std::filesystem::file_size(path, ec);
    if (ec || !std::filesystem::is_regular_file(path, ec))
        throw Error("environment map " + path + ": not a readable regular file");
    if (size > (uint64_t(4) << 30)) throw Error("environment map " + path + ": over 4 GiB");
    std::vector<unsigned char> bytes(size);
    std::ifstream in(path, std::ios::binary);
    if (!in || !in.read(reinterpret_cast<char*>(bytes.data()), std::streamsize(size)))
        throw Error("environment map " + path + ": cannot be read");
    return load_environment_memory(bytes.data(), bytes.size(), path);
}

Environment constant_environment(const glm::vec3& rgb) {
    if (!std::isfinite(rgb.x + rgb.y + rgb.z) || rgb.x < 0.f || rgb.y < 0.f || rgb.z < 0.f)
        throw Error("the background must be three finite values >= 0");
    Environment env;
    env.name = "background";
    env.width = 32, env.height = 16;
    env.rgb.resize(size_t(env.width) * size_t(env.height) * 3);
    for (size_t i = 0; i < env.rgb.size(); i += 3)
        env.rgb[i] = rgb.x, env.rgb[i + 1] = rgb.y, env.rgb[i + 2] = rgb.z;
    return env;
}

uint64_t environment_device_bytes(int width, int height) {
    const uint64_t texels = uint64_t(width) * uint64_t(height);
    return texels * 24 + uint64_t(height) * 8 + 12;
}

int shrink_environment(Environment& env, uint64_t max_bytes) {
    int halvings = 0;
    while (environment_device_bytes(env.width, env.height) > max_bytes) {
        if (env.width <= 2 && env.height <= 1)
            throw Error("environment map " + env.name + " does not fit the device even at 2x1");
        // Each texel of the half map: the mean of the 2x2 (or 2x1, 1x2) texels it covers.
        const int w = std::max(1, env.width / 2), h = std::max(1, env.height / 2);
        const int fx = env.width / w, fy = env.height / h;
        std::vector<float> out(size_t(w) * size_t(h) * 3, 0.f);
        for (int y = 0; y < h; ++y)
            for (int x = 0; x < w; ++x)
                for (int c = 0; c < 3; ++c) {
                    double sum = 0;
                    for (int dy = 0; dy < fy; ++dy)
                        for (int dx = 0; dx < fx; ++dx)
                            sum += env.rgb[(size_t(y * fy + dy) * size_t(env.width) +
                                            size_t(x * fx + dx)) * 3 + size_t(c)];
                    out[(size_t(y) * size_t(w) + size_t(x)) * 3 + size_t(c)] =
                        float(sum / double(fx * fy));
                }
        env.rgb = std::move(out);
        env.width = w, env.height = h;
        ++halvings;
    }
    return halvings;
}

}  // namespace mcpt
