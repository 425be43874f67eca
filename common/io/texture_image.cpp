// PNG and JPEG through stb_image, WebP through libwebp.
#include "common/io/texture_image.h"

#include <stb_image.h>

#include <climits>
#include <cstring>

#include "common/error.h"

#if defined(MCPT_WITH_WEBP)
#include <webp/decode.h>
#endif

namespace mcpt {
namespace {

bool starts_with(const unsigned char* bytes, size_t size, const char* magic, size_t offset = 0) {
    const size_t n = std::strlen(magic);
    return size >= offset + n && std::memcmp(bytes + offset, magic, n) == 0;
}

bool is_webp(const unsigned char* bytes, size_t size) {
    return starts_with(bytes, size, "RIFF") && starts_with(bytes, size, "WEBP", 8);
}

}  // namespace

bool has_webp_decoder() {
#if defined(MCPT_WITH_WEBP)
    return true;
#else
    return false;
#endif
}

TextureImageInfo texture_image_info(const unsigned char* bytes, size_t size) {
    TextureImageInfo info;
    if (size > size_t(INT_MAX)) throw Error("image larger than 2 GiB");
    if (is_webp(bytes, size)) {
        info.format = "WebP";
#if defined(MCPT_WITH_WEBP)
        if (!WebPGetInfo(bytes, size, &info.width, &info.height))
            throw Error("WebP image with a broken header");
        return info;
#else
        throw Error("WebP image, and this build has no WebP decoder (Debian: libwebp-dev)");
#endif
    }
    if (starts_with(bytes, size, "\xABKTX 20\xBB"))
        throw Error(
            "KTX2 image (KHR_texture_basisu): no KTX2 decoder is packaged for Debian 12; "
            "export the textures as PNG, JPEG or WebP instead (gltfpack without -tc, "
            "gltf-transform without etc1s/uastc)");
    int channels = 0;
    if (!stbi_info_from_memory(bytes, int(size), &info.width, &info.height, &channels))
        throw Error(std::string("not a PNG, JPEG or WebP image (") +
                    (stbi_failure_reason() ? stbi_failure_reason() : "unknown format") + ")");
    info.format = starts_with(bytes, size, "\x89PNG") ? "PNG" : "JPEG";
    return info;
}

std::vector<unsigned char> decode_texture_image(const unsigned char* bytes, size_t size,
                                                const TextureImageInfo& info) {
    std::vector<unsigned char> out;
    int w = 0, h = 0;
    if (info.format == "WebP") {
#if defined(MCPT_WITH_WEBP)
        uint8_t* rgba = WebPDecodeRGBA(bytes, size, &w, &h);
        if (!rgba) throw Error("WebP image does not decode (truncated or corrupt)");
        if (w == info.width && h == info.height) out.assign(rgba, rgba + size_t(w) * size_t(h) * 4);
        WebPFree(rgba);
#endif
    } else {
        int channels = 0;
        unsigned char* rgba = stbi_load_from_memory(bytes, int(size), &w, &h, &channels, 4);
        if (!rgba)
            throw Error(std::string("cannot decode ") + info.format + " image (" +
                        (stbi_failure_reason() ? stbi_failure_reason() : "unknown error") + ")");
        if (w == info.width && h == info.height) out.assign(rgba, rgba + size_t(w) * size_t(h) * 4);
        stbi_image_free(rgba);
    }
    if (out.empty())
        throw Error(info.format + " image decoded to " + std::to_string(w) + "x" +
                    std::to_string(h) + " texels, its header says " + std::to_string(info.width) +
                    "x" + std::to_string(info.height));
    return out;
}

}  // namespace mcpt
