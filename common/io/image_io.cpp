// EXR through tinyexr (Debian's shared libtinyexr), PNG through stb_image_write (implementation
// in stb_impl.cpp).
#include "common/io/image_io.h"

#include <stb_image_write.h>
#include <tinyexr.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>

#include "common/error.h"
#include "common/io/atomic_file.h"

namespace mcpt {

namespace {

// Lower-case extension including the dot ("" when there is none)
std::string extension_of(const std::string& path) {
    const size_t slash = path.find_last_of("/\\");
    const size_t dot = path.find_last_of('.');
    if (dot == std::string::npos || (slash != std::string::npos && dot < slash)) return "";
    std::string ext = path.substr(dot);
    for (char& c : ext) c = char(std::tolower(static_cast<unsigned char>(c)));
    return ext;
}

// Takes ownership of a tinyexr error message and returns it as a string
std::string take_exr_error(const char* err) {
    std::string msg = err ? err : "unknown error";
    if (err) FreeEXRErrorMessage(err);
    return msg;
}

// To `path`, or (path empty) into `memory`.
void write_exr(const std::string& path, int width, int height, const std::vector<float>& rgb,
               std::vector<unsigned char>* memory = nullptr) {
    // Split into planes in the customary alphabetical channel order B, G, R
    const size_t n = size_t(width) * size_t(height);
    std::vector<float> planes[3];
    for (int c = 0; c < 3; ++c) planes[c].resize(n);
    for (size_t i = 0; i < n; ++i) {
        planes[0][i] = rgb[3 * i + 2];
        planes[1][i] = rgb[3 * i + 1];
        planes[2][i] = rgb[3 * i + 0];
    }
    unsigned char* images[3] = {reinterpret_cast<unsigned char*>(planes[0].data()),
                                reinterpret_cast<unsigned char*>(planes[1].data()),
                                reinterpret_cast<unsigned char*>(planes[2].data())};

    EXRImage image;
    InitEXRImage(&image);
    image.images = images;
    image.width = width;
    image.height = height;
    image.num_channels = 3;

    // Header: three 32-bit float channels, lossless ZIP compression
    EXRChannelInfo channels[3];
    std::memset(channels, 0, sizeof(channels));
    const char* names[3] = {"B", "G", "R"};
    int pixel_types[3], requested_types[3];
    for (int c = 0; c < 3; ++c) {
        std::strcpy(channels[c].name, names[c]);
        pixel_types[c] = TINYEXR_PIXELTYPE_FLOAT;
        requested_types[c] = TINYEXR_PIXELTYPE_FLOAT;
    }
    EXRHeader header;
    InitEXRHeader(&header);
    header.num_channels = 3;
    header.channels = channels;
    header.pixel_types = pixel_types;
    header.requested_pixel_types = requested_types;
    header.compression_type = TINYEXR_COMPRESSIONTYPE_ZIP;

    const char* err = nullptr;
    if (memory) {
        unsigned char* bytes = nullptr;
        const size_t size = SaveEXRImageToMemory(&image, &header, &bytes, &err);
        if (size == 0 || !bytes) throw Error("cannot encode EXR: " + take_exr_error(err));
        memory->assign(bytes, bytes + size);
        std::free(bytes);
        return;
    }
    if (SaveEXRImageToFile(&image, &header, path.c_str(), &err) != TINYEXR_SUCCESS)
        throw Error("cannot write image " + path + ": " + take_exr_error(err));
}

// Every pixel as 8-bit sRGB; non-finite pixels become magenta.
std::vector<uint8_t> srgb8_pixels(int width, int height, const std::vector<float>& rgb) {
    const size_t n = size_t(width) * size_t(height);
    std::vector<uint8_t> bytes(3 * n);
    for (size_t i = 0; i < n; ++i) {
        const float* p = &rgb[3 * i];
        if (!std::isfinite(p[0]) || !std::isfinite(p[1]) || !std::isfinite(p[2])) {
            bytes[3 * i + 0] = 255;
            bytes[3 * i + 1] = 0;
            bytes[3 * i + 2] = 255;
            continue;
        }
        for (int c = 0; c < 3; ++c) bytes[3 * i + c] = linear_to_srgb8(p[c]);
    }
    return bytes;
}

void write_png(const std::string& path, int width, int height, const std::vector<float>& rgb) {
    const std::vector<uint8_t> bytes = srgb8_pixels(width, height, rgb);
    if (!stbi_write_png(path.c_str(), width, height, 3, bytes.data(), 3 * width))
        throw Error("cannot write image " + path);
}

void check_rgb_size(const std::string& what, int width, int height, size_t floats) {
    if (width <= 0 || height <= 0 || floats != 3 * size_t(width) * size_t(height))
        throw Error("cannot write image " + what + ": " + std::to_string(floats) +
                    " values do not make a " + std::to_string(width) + "x" +
                    std::to_string(height) + " RGB image");
}

}  // namespace

uint8_t linear_to_srgb8(float linear) {
    // Clamp, exact sRGB OETF, round to nearest
    if (!(linear > 0.0f)) return 0;
    if (linear >= 1.0f) return 255;
    const double v = linear;
    const double s = v <= 0.0031308 ? 12.92 * v : 1.055 * std::pow(v, 1.0 / 2.4) - 0.055;
    return uint8_t(std::clamp(std::lround(s * 255.0), 0L, 255L));
}

std::vector<unsigned char> encode_png8(int width, int height, const std::vector<uint8_t>& rgb8) {
    check_rgb_size("(PNG)", width, height, rgb8.size());
    std::vector<unsigned char> out;
    const auto append = [](void* context, void* data, int size) {
        auto* bytes = static_cast<std::vector<unsigned char>*>(context);
        bytes->insert(bytes->end(), static_cast<unsigned char*>(data),
                      static_cast<unsigned char*>(data) + size);
    };
    if (!stbi_write_png_to_func(append, &out, width, height, 3, rgb8.data(), 3 * width))
        throw Error("cannot encode PNG");
    return out;
}

std::vector<unsigned char> encode_image(const std::string& format, int width, int height,
                                        const std::vector<float>& rgb) {
    check_rgb_size("(" + format + ")", width, height, rgb.size());
    if (format == "png") return encode_png8(width, height, srgb8_pixels(width, height, rgb));
    if (format != "exr") throw Error("unsupported image format \"" + format + "\", use exr or png");
    std::vector<unsigned char> out;
    write_exr("", width, height, rgb, &out);
    return out;
}

void check_image_path(const std::string& path) {
    const std::string ext = extension_of(path);
    if (ext != ".exr" && ext != ".png")
        throw Error("unsupported image format \"" + ext + "\" for " + path + ", use .exr or .png");
    // The folder must exist and take new files.
    const std::filesystem::path p(path);
    const std::filesystem::path dir = p.has_parent_path() ? p.parent_path() : ".";
    std::error_code ec;
    if (!std::filesystem::is_directory(dir, ec))
        throw Error("cannot write " + path + ": no folder " + dir.string());
    if (access(dir.c_str(), W_OK) != 0)
        throw Error("cannot write " + path + ": folder " + dir.string() + " is not writable");
}

void write_image(const std::string& path, int width, int height, const std::vector<float>& rgb) {
    // Check the format and the buffer before touching the file
    const std::string ext = extension_of(path);
    if (ext != ".exr" && ext != ".png")
        throw Error("unsupported image format \"" + ext + "\" for " + path + ", use .exr or .png");
    check_rgb_size(path, width, height, rgb.size());
    // Whole or not at all: into a temporary file, then renamed.
    write_atomically(path, [&](const std::string& tmp) {
        if (ext == ".exr")
            write_exr(tmp, width, height, rgb);
        else
            write_png(tmp, width, height, rgb);
    });
}

std::vector<unsigned char> read_file_bytes(const std::string& path, const std::string& what) {
    std::error_code ec;
    const auto size = std::filesystem::file_size(path, ec);
    if (ec || !std::filesystem::is_regular_file(path, ec))
        throw Error(what + " " + path + ": not a readable regular file");
    if (size > (uint64_t(4) << 30)) throw Error(what + " " + path + ": over 4 GiB");
    std::vector<unsigned char> bytes(size);
    std::ifstream in(path, std::ios::binary);
    if (!in || !in.read(reinterpret_cast<char*>(bytes.data()), std::streamsize(size)))
        throw Error(what + " " + path + ": cannot be read");
    return bytes;
}

std::vector<float> read_exr(const std::string& path, int& width, int& height) {
    const std::vector<unsigned char> bytes = read_file_bytes(path, "cannot read EXR image");
    return read_exr_memory(bytes.data(), bytes.size(), path, width, height);
}

std::vector<float> read_exr_memory(const unsigned char* data, size_t size, const std::string& path,
                                   int& width, int& height) {
    // Header and pixels through tinyexr's lower-level calls, each freed by its owner (LoadEXR
    // leaks the header's channel list when the pixels fail to decode; a failed pixel load
    // frees its own buffers but leaves their pointers, so only a loaded image is freed).
    struct Owned {
        EXRHeader header;
        EXRImage image;
        bool image_loaded = false;
        Owned() { InitEXRHeader(&header), InitEXRImage(&image); }
        ~Owned() {
            if (image_loaded) FreeEXRImage(&image);
            FreeEXRHeader(&header);
        }
    } exr;
    const auto fail = [&](const std::string& why) {
        return Error("cannot read EXR image " + path + ": " + why);
    };
    EXRVersion version;
    if (ParseEXRVersionFromMemory(&version, data, size) != TINYEXR_SUCCESS)
        throw fail("not an OpenEXR file");
    if (version.multipart || version.non_image)
        throw fail("multi-part and deep files are not read");
    const char* err = nullptr;
    if (ParseEXRHeaderFromMemory(&exr.header, &version, data, size, &err) != TINYEXR_SUCCESS)
        throw fail(take_exr_error(err));
    if (exr.header.tiled) throw fail("tiled files are not read (mcpt writes scan lines)");
    // The image size before tinyexr allocates it: at most what mcpt renders.
    const EXRBox2i& w = exr.header.data_window;
    const int64_t wide = int64_t(w.max_x) - w.min_x + 1, high = int64_t(w.max_y) - w.min_y + 1;
    if (wide < 1 || high < 1 || wide > 16384 || high > 16384)
        throw fail("data window " + std::to_string(wide) + "x" + std::to_string(high) +
                   " outside 1x1 to 16384x16384");
    int rgb_channel[3] = {-1, -1, -1};
    for (int c = 0; c < exr.header.num_channels; ++c) {
        exr.header.requested_pixel_types[c] = TINYEXR_PIXELTYPE_FLOAT;
        const std::string name = exr.header.channels[c].name;
        for (int k = 0; k < 3; ++k)
            if (name == std::string(1, "RGB"[k])) rgb_channel[k] = c;
    }
    if (exr.header.num_channels == 1) rgb_channel[0] = rgb_channel[1] = rgb_channel[2] = 0;
    if (*std::min_element(rgb_channel, rgb_channel + 3) < 0) throw fail("no R, G and B channels");
    if (LoadEXRImageFromMemory(&exr.image, &exr.header, data, size, &err) != TINYEXR_SUCCESS)
        throw fail(take_exr_error(err));
    exr.image_loaded = true;
    if (!exr.image.images || exr.image.width != wide || exr.image.height != high)
        throw fail("pixels do not match the header");
    width = exr.image.width, height = exr.image.height;
    const size_t n = size_t(width) * size_t(height);
    std::vector<float> rgb(3 * n);
    for (int k = 0; k < 3; ++k) {
        const float* plane = reinterpret_cast<const float*>(exr.image.images[rgb_channel[k]]);
        for (size_t i = 0; i < n; ++i) rgb[3 * i + k] = plane[i];
    }
    return rgb;
}

}  // namespace mcpt
