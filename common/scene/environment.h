// Environment light for a scene: an equirectangular map of linear radiance read from .exr
// (OpenEXR: every compression, Blender's DWAB included; tinyexr where OpenEXR is not built
// in) or Radiance .hdr (stb_image), or a constant background colour; and the host side
// of its importance sampling (per-texel weights luminance * sin(theta), as pbrt-v4 and Cycles).
#pragma once
#include <cstddef>
#include <cstdint>
#include <string>

#include "common/scene/scene.h"

namespace mcpt {

// The largest map read: 16384 x 8192 texels.
constexpr int kMaxEnvironmentWidth = 16384;

// Reads an equirectangular map from a .exr or .hdr file (by its first bytes, not its name).
// Throws mcpt::Error naming the file: unreadable, another format, a size outside 1x1 to
// 16384x8192, or non-finite texels (negative ones are clamped to 0).
Environment load_environment(const std::string& path);
Environment load_environment_memory(const unsigned char* data, size_t size,
                                    const std::string& name);

// A constant background of radiance `rgb` as a small map (32 x 16 texels of one colour), so
// that it is lit, sampled and seen exactly as a map.
Environment constant_environment(const glm::vec3& rgb);

// Bytes the map takes on the device: 16 per texel (radiance and pdf), 8 per texel and per
// row (the alias tables), and up to 12 of alignment.
uint64_t environment_device_bytes(int width, int height);

// Halves the map (2x2 box filter: its mean radiance is kept) until it needs at most
// `max_bytes` on the device; returns how many times it halved it. Throws mcpt::Error if even
// a 2x1 map does not fit.
int shrink_environment(Environment& env, uint64_t max_bytes);

// Luminance (Rec. 709) of a texel: what the sampling weights follow (in double: texels near
// the float limit stay finite).
inline double env_luminance(float r, float g, float b) {
    return 0.2126 * double(r) + 0.7152 * double(g) + 0.0722 * double(b);
}

}  // namespace mcpt
