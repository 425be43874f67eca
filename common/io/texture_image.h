// Encoded texture images (PNG and JPEG through stb_image, WebP through libwebp) decoded to
// 8-bit RGBA, the size read from the header first so that a caller can refuse it before any
// texel is allocated.
#pragma once
#include <cstddef>
#include <string>
#include <vector>

namespace mcpt {

struct TextureImageInfo {
    std::string format;  // "PNG", "JPEG", "WebP"
    int width = 0, height = 0;
};

// The format and size in the header; throws mcpt::Error naming the format it found when the
// bytes are no image this build decodes (KTX2 and Basis are named, with what to do instead).
TextureImageInfo texture_image_info(const unsigned char* bytes, size_t size);

// The texels, row 0 first, four bytes each (RGBA; alpha 255 where the image has none).
// Throws mcpt::Error when the data do not decode or disagree with their header.
std::vector<unsigned char> decode_texture_image(const unsigned char* bytes, size_t size,
                                                const TextureImageInfo& info);

// Whether this build decodes WebP (Debian: libwebp-dev).
bool has_webp_decoder();

}  // namespace mcpt
