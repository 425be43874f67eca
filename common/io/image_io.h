// Image output for renders (linear EXR, 8-bit sRGB PNG) and EXR input for tests and tools.
#pragma once
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace mcpt {

// Writes linear radiance `rgb` (3 floats per pixel, row-major, top row first) to `path`; the
// format follows the extension, case-insensitively:
//   .exr  32-bit float R, G, B channels, values written unchanged (ZIP compressed, lossless)
//   .png  8-bit sRGB: exposure 1, clamped to [0, 1], exact sRGB curve, rounded; a pixel with
//         any non-finite channel is written magenta
// Throws mcpt::Error for another extension, a size mismatch, or a file that cannot be written.
void write_image(const std::string& path, int width, int height, const std::vector<float>& rgb);

// The bytes write_image() would write, for `format` "exr" or "png" (downloads, reports).
std::vector<unsigned char> encode_image(const std::string& format, int width, int height,
                                        const std::vector<float>& rgb);
// 8-bit RGB pixels (3 per pixel, top row first; false-colour maps, screenshots) as PNG bytes.
std::vector<unsigned char> encode_png8(int width, int height, const std::vector<uint8_t>& rgb8);

// Throws mcpt::Error unless `path` has a format write_image() writes and names a file in an
// existing, writable folder: what a command checks before it renders.
void check_image_path(const std::string& path);

// The bytes of a regular file of at most 4 GiB; throws mcpt::Error "<what> <path>: <why>".
std::vector<unsigned char> read_file_bytes(const std::string& path, const std::string& what);

// Reads the R, G, B channels (a single channel as gray) of a scan-line EXR file of at most
// 16384x16384 pixels (3 floats per pixel, top row first, half channels widened to float);
// throws mcpt::Error naming the file when it cannot be read.
std::vector<float> read_exr(const std::string& path, int& width, int& height);
// The same from `size` bytes in memory; `name` names them in errors.
std::vector<float> read_exr_memory(const unsigned char* data, size_t size, const std::string& name,
                                   int& width, int& height);

// Linear value -> 8-bit sRGB as written to PNG: clamp to [0, 1], sRGB OETF, round to nearest.
// Non-finite input maps to 0 (write_image paints such pixels magenta instead).
uint8_t linear_to_srgb8(float linear);

}  // namespace mcpt
