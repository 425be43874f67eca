#include "common/scene/environment.h"

#include <stb_image.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <stdexcept>
#include <vector>

#include "common/error.h"
#include "common/io/image_io.h"

#if MCPT_WITH_OPENEXR
#include <ImfChannelList.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfIO.h>
#include <ImfInputFile.h>
#include <ImfRgbaFile.h>
#endif

namespace mcpt {

namespace {

#if MCPT_WITH_OPENEXR
// OpenEXR reading from memory (the bytes of a file or of an asset).
class MemoryStream : public Imf::IStream {
  public:
    MemoryStream(const unsigned char* data, size_t size, const std::string& name)
        : Imf::IStream(name.c_str()), data_(data), size_(size) {}
    bool read(char c[], int n) override {
        if (n < 0 || uint64_t(n) > size_ - pos_) throw std::runtime_error("unexpected end of file");
        std::memcpy(c, data_ + pos_, size_t(n));
        pos_ += uint64_t(n);
        return pos_ < size_;
    }
    uint64_t tellg() override { return pos_; }
    void seekg(uint64_t pos) override { pos_ = std::min<uint64_t>(pos, size_); }

  private:
    const unsigned char* data_;
    uint64_t size_, pos_ = 0;
};

// R, G, B (or Y, as grey) of a scan-line or tiled EXR of any compression, as floats.
std::vector<float> read_openexr(const unsigned char* data, size_t size, const std::string& name,
                                int& width, int& height) {
    try {
        MemoryStream stream(data, size, name);
        Imf::InputFile file(stream);
        const Imath::Box2i dw = file.header().dataWindow();
        const int64_t w = int64_t(dw.max.x) - dw.min.x + 1, h = int64_t(dw.max.y) - dw.min.y + 1;
        if (w < 1 || h < 1 || w > kMaxEnvironmentWidth || h > kMaxEnvironmentWidth / 2)
            throw Error("environment map " + name + ": " + std::to_string(w) + "x" +
                        std::to_string(h) + " texels, outside 1x1 to 16384x8192");
        const Imf::ChannelList& channels = file.header().channels();
        const bool rgb =
            channels.findChannel("R") && channels.findChannel("G") && channels.findChannel("B");
        const bool luma = channels.findChannel("Y") != nullptr;
        const bool chroma = channels.findChannel("RY") || channels.findChannel("BY");
        if (!rgb && !luma)
            throw Error("environment map " + name + ": no R, G and B (or Y) channels");
        width = int(w), height = int(h);
        const size_t n = size_t(w) * size_t(h);
        std::vector<float> out(3 * n);
        if (!rgb && chroma) {
            // Luminance-chroma (Y, RY, BY; chroma subsampled, half floats): OpenEXR's RGBA
            // interface converts it back to RGB.
            if (!channels.findChannel("RY") || !channels.findChannel("BY"))
                throw Error("environment map " + name +
                            ": luminance-chroma with only one of RY and BY");
            MemoryStream again(data, size, name);
            Imf::RgbaInputFile yc(again);
            std::vector<Imf::Rgba> px(n);
            yc.setFrameBuffer(px.data() - (int64_t(dw.min.x) + int64_t(dw.min.y) * w), 1,
                              size_t(w));
            yc.readPixels(dw.min.y, dw.max.y);
            for (size_t i = 0; i < n; ++i)
                out[3 * i] = px[i].r, out[3 * i + 1] = px[i].g, out[3 * i + 2] = px[i].b;
            return out;
        }
        // R, G and B as planes; a grey (Y only) map fills one plane, copied to all three (a
        // frame buffer maps each channel name to one slice).
        const int planes_read = rgb ? 3 : 1;
        std::vector<float> planes(size_t(planes_read) * n);
        Imf::FrameBuffer fb;
        for (int k = 0; k < planes_read; ++k) {
            // The slice's origin is pixel (0, 0), which the data window may not contain.
            char* base = reinterpret_cast<char*>(planes.data() + size_t(k) * n) -
                         (int64_t(dw.min.x) + int64_t(dw.min.y) * w) * int64_t(sizeof(float));
            fb.insert(rgb ? std::string(1, "RGB"[k]) : std::string("Y"),
                      Imf::Slice(Imf::FLOAT, base, sizeof(float), size_t(w) * sizeof(float)));
        }
        file.setFrameBuffer(fb);
        file.readPixels(dw.min.y, dw.max.y);
        for (size_t i = 0; i < n; ++i)
            for (size_t k = 0; k < 3; ++k) out[3 * i + k] = planes[(rgb ? k : 0) * n + i];
        return out;
    } catch (const Error&) {
        throw;
    } catch (const std::exception& e) {
        throw Error("environment map " + name + ": " + e.what());
    }
}
#endif

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

// A Radiance .hdr walked as stb_image will read it, before it does: Debian's stb_image 2.27
// loops forever on a dump of length 0 (CVE-2021-42715) and fills a file that ends early with
// zeros. Throws "corrupt" naming the row; what passes, stb decodes within the bytes given.
void check_radiance(const unsigned char* data, size_t size, const std::string& name, int width,
                    int height) {
    const auto corrupt = [&](const std::string& why) {
        return Error("environment map " + name + ": corrupt Radiance .hdr (" + why + ")");
    };
    size_t at = 0;
    // Header lines (stb's tokens end at '\n') up to an empty one, then the resolution line.
    const auto line = [&](std::string& out) {
        out.clear();
        while (at < size && data[at] != '\n') {
            if (out.size() < 1024) out.push_back(char(data[at]));
            ++at;
        }
        if (at >= size) throw corrupt("the header does not end");
        ++at;
    };
    std::string text;
    line(text);  // #?RADIANCE
    do line(text);
    while (!text.empty());
    line(text);  // the resolution (width and height as stb read them)
    const uint64_t w = uint64_t(width), h = uint64_t(height), flat = 4 * w * h;
    // Flat RGBE pixels: stb reads them so when the width rules run-length encoding out.
    if (w < 8 || w >= 32768) {
        if (size - at < flat) throw corrupt("ends before its last pixel");
        return;
    }
    for (uint64_t row = 0; row < h; ++row) {
        const std::string where = "row " + std::to_string(row);
        if (size - at < 4) throw corrupt("ends at " + where);
        const unsigned char* r = data + at;
        if (r[0] != 2 || r[1] != 2 || (r[2] & 0x80)) {
            // Not run-length encoded: stb then reads every pixel flat, from the first row.
            if (row != 0) throw corrupt(where + " is not run-length encoded as those before");
            if (size - at < flat) throw corrupt("ends before its last pixel");
            return;
        }
        if ((uint64_t(r[2]) << 8 | r[3]) != w) throw corrupt(where + " has another width");
        at += 4;
        // Four channels, each a sequence of runs (count > 128: count - 128 copies of one byte)
        // and dumps (count bytes), together exactly the width.
        for (int channel = 0; channel < 4; ++channel)
            for (uint64_t x = 0; x < w;) {
                if (at >= size) throw corrupt("ends in " + where);
                uint64_t count = data[at++];
                const bool run = count > 128;
                if (run) count -= 128;
                if (count == 0) throw corrupt("a dump of length 0 in " + where);
                if (count > w - x) throw corrupt("a run past the end of " + where);
                const uint64_t bytes = run ? 1 : count;
                if (size - at < bytes) throw corrupt("ends in " + where);
                at += bytes, x += count;
            }
    }
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
#if MCPT_WITH_OPENEXR
        std::vector<float> rgb = read_openexr(data, size, name, w, h);
#else
        std::vector<float> rgb = read_exr_memory(data, size, name, w, h);
#endif
        return checked(std::move(rgb), w, h, name);
    }
    if (starts_with(data, size, "#?RADIANCE") || starts_with(data, size, "#?RGBE")) {
        if (size > size_t(INT32_MAX)) throw Error("environment map " + name + ": over 2 GiB");
        int w = 0, h = 0, channels = 0;
        // The size first, so that nothing larger than the limit is decoded.
        if (!stbi_info_from_memory(data, int(size), &w, &h, &channels))
            throw Error("environment map " + name + ": " + stbi_failure_reason());
        if (w < 1 || h < 1 || w > kMaxEnvironmentWidth || h > kMaxEnvironmentWidth / 2)
            return checked({}, w, h, name);  // throws the size error
        check_radiance(data, size, name, w, h);
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
    const std::vector<unsigned char> bytes = read_file_bytes(path, "environment map");
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
    // Texels (16 bytes), each row's column CDF and guide (2 width + 1 words), the rows' (2
    // height + 1), alignment.
    return texels * 24 + uint64_t(height) * 12 + 4 + 12;
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
                                            size_t(x * fx + dx)) *
                                               3 +
                                           size_t(c)];
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
