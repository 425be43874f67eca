#include "common/render/checkpoint.h"

#include <algorithm>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "common/error.h"
#include "common/io/atomic_file.h"
#include "common/io/host_memory.h"

namespace mcpt {

namespace {

constexpr char kMagic[8] = {'M', 'C', 'P', 'T', 'C', 'K', 'P', 'T'};
constexpr uint32_t kFormat = 2;
// The largest fingerprint a checkpoint may hold (they are a few hundred bytes).
constexpr uint32_t kMaxFingerprintBytes = 1u << 16;
constexpr uint64_t kFnvBasis = 0xcbf29ce484222325ull, kFnvPrime = 0x100000001b3ull;

uint64_t fnv1a(const void* data, size_t size, uint64_t h = kFnvBasis) {
    const unsigned char* p = static_cast<const unsigned char*>(data);
    for (size_t i = 0; i < size; ++i) h = (h ^ p[i]) * kFnvPrime;
    return h;
}

// Appends plain values and arrays to a byte string.
struct Writer {
    std::string bytes;
    template <typename T>
    void put(const T& v) {
        bytes.append(reinterpret_cast<const char*>(&v), sizeof v);
    }
    void put(const std::vector<double>& v) {
        bytes.append(reinterpret_cast<const char*>(v.data()), v.size() * sizeof(double));
    }
};

}  // namespace

std::string encode_fingerprint(const Fingerprint& f) {
    std::string text;
    for (const auto& [key, value] : f) text += key + "=" + value + "\n";
    return text;
}

Fingerprint decode_fingerprint(const std::string& text) {
    Fingerprint f;
    std::istringstream lines(text);
    for (std::string line; std::getline(lines, line);) {
        const size_t eq = line.find('=');
        if (eq == std::string::npos) continue;
        f.emplace_back(line.substr(0, eq), line.substr(eq + 1));
    }
    return f;
}

std::string fingerprint_value(const Fingerprint& f, const std::string& key) {
    for (const auto& [k, v] : f)
        if (k == key) return v;
    return "(missing)";
}

std::string fingerprint_difference(const Fingerprint& a, const Fingerprint& b,
                                   const std::vector<std::string>& ignored) {
    for (const Fingerprint* x : {&a, &b})
        for (const auto& [key, value] : *x) {
            if (std::find(ignored.begin(), ignored.end(), key) != ignored.end()) continue;
            if (fingerprint_value(x == &a ? b : a, key) != value) return key;
        }
    return "";
}

namespace {

// How a saved value differs from the current one, in words.
std::string difference(const std::string& key, const std::string& saved, const std::string& now) {
    if (key == "mcpt") return "written by mcpt " + saved + ", this is mcpt " + now;
    if (key == "scene") return "written for another scene (" + saved + "; now " + now + ")";
    if (key == "device") return "rendered on " + saved + ", this session is on " + now;
    return "written with other options: " + key + " " + saved + " (now " + now + ")";
}

}  // namespace

uint64_t scene_hash(const Scene& s) {
    uint64_t h = kFnvBasis;
    for (const Triangle& t : s.triangles) h = fnv1a(&t, sizeof t, h);
    for (const Sphere& sp : s.spheres) h = fnv1a(&sp, sizeof sp, h);
    for (const Material& m : s.materials) {
        h = fnv1a(&m.type, sizeof m.type, h);
        h = fnv1a(&m.color, sizeof m.color, h);
        h = fnv1a(&m.emission, sizeof m.emission, h);
        if (m.two_sided) h = fnv1a(&m.two_sided, sizeof m.two_sided, h);
        h = fnv1a(&m.ior, sizeof m.ior, h);
        const float pbr[] = {m.metallic, m.roughness, m.specular, m.alpha_cutoff};
        const int tex[] = {m.tex_base, m.tex_metal_rough, m.tex_normal, m.tex_emission};
        h = fnv1a(pbr, sizeof pbr, h);
        h = fnv1a(tex, sizeof tex, h);
    }
    for (const VertexAttributes& a : s.attributes) h = fnv1a(&a, sizeof a, h);
    for (const Texture& t : s.textures) {
        const int head[] = {t.width, t.height, int(t.wrap_s), int(t.wrap_t), int(t.nearest)};
        h = fnv1a(head, sizeof head, h);
        if (!t.rgba.empty()) h = fnv1a(t.rgba.data(), t.rgba.size() * sizeof(uint16_t), h);
    }
    for (const PunctualLight& l : s.punctual_lights) {
        const float f[] = {float(l.kind), l.position.x,  l.position.y,  l.position.z,
                           l.direction.x, l.direction.y, l.direction.z, l.intensity.x,
                           l.intensity.y, l.intensity.z, l.range,       l.inner_cone,
                           l.outer_cone};
        h = fnv1a(f, sizeof f, h);
    }
    if (s.environment.present()) {
        const Environment& e = s.environment;
        // The sampling too: each sample's value depends on it (not the image it converges to).
        const float head[] = {float(e.width), float(e.height), e.rotate_deg, e.scale,
                              e.compensated ? 1.f : 0.f};
        h = fnv1a(head, sizeof head, h);
        h = fnv1a(e.rgb.data(), e.rgb.size() * sizeof(float), h);
    }
    // How lights are picked: each sample's value depends on it.
    const uint8_t tree = s.light_tree ? 1 : s.light_by_contribution ? 2 : 0;
    h = fnv1a(&tree, 1, h);
    using Tls = Scene::TriangleLightSampling;
    const Tls tls = s.triangle_light_sampling;
    const uint8_t by_area = tls == Tls::Area        ? 1
                            : tls == Tls::Triangles ? 2
                            : tls == Tls::Uniform   ? 3
                            : tls == Tls::Cosine    ? 4
                                                    : 0;
    h = fnv1a(&by_area, 1, h);
    h = fnv1a(&s.camera, sizeof s.camera, h);
    h = fnv1a(&s.has_camera, sizeof s.has_camera, h);
    return fnv1a(&s.max_depth_hint, sizeof s.max_depth_hint, h);
}

void write_checkpoint(const std::string& path, const Fingerprint& fingerprint,
                      const RenderResult& r) {
    // Magic, format, fingerprint, scalars, arrays, then the checksum of all before it.
    Writer w;
    w.bytes.append(kMagic, sizeof kMagic);
    w.put(kFormat);
    const std::string text = encode_fingerprint(fingerprint);
    if (text.size() > kMaxFingerprintBytes)
        throw Error("cannot write checkpoint '" + path + "': its fingerprint is over 64 KiB");
    w.put(uint32_t(text.size()));
    w.bytes += text;
    w.put(uint32_t(r.width)), w.put(uint32_t(r.height));
    w.put(uint64_t(r.spp)), w.put(uint64_t(r.nonfinite_total));
    w.put(r.rays), w.put(r.seconds);
    w.put(uint64_t(r.first)), w.put(uint32_t(r.exact.empty() ? 0 : 1));
    w.put(r.sum), w.put(r.sum_sq), w.put(r.nonfinite);
    if (!r.exact.empty())
        w.bytes.append(reinterpret_cast<const char*>(r.exact.data()),
                       r.exact.size() * sizeof(ExactSum));
    w.put(fnv1a(w.bytes.data(), w.bytes.size()));
    write_atomically(path, [&](const std::string& tmp) {
        std::ofstream f(tmp, std::ios::binary);
        f.write(w.bytes.data(), std::streamsize(w.bytes.size()));
        f.flush();
        if (!f) throw Error("cannot write checkpoint '" + path + "'");
    });
}

namespace {

// Reads a checkpoint from `in` (`size` bytes): the header first, checked against the size it
// implies, then exactly the arrays it announces, with the checksum over every byte before it.
// With `header_only` the arrays are not read (their size is still checked).
RenderResult parse(std::istream& in, uint64_t size, const std::string& name,
                   const Fingerprint* expected, Fingerprint* written, bool header_only) {
    const auto fail = [&](const std::string& why) {
        return Error("checkpoint '" + name + "' refused: " + why);
    };
    uint64_t hash = kFnvBasis, at = 0;
    // The next n bytes (within the size), added to the checksum.
    const auto take = [&](void* out, uint64_t n) {
        if (size - at < n) throw fail("truncated");
        if (!in.read(static_cast<char*>(out), std::streamsize(n))) throw fail("cannot read it");
        hash = fnv1a(out, size_t(n), hash);
        at += n;
    };
    char magic[8];
    if (size < sizeof magic) throw fail("not an mcpt checkpoint");
    take(magic, 8);
    if (std::memcmp(magic, kMagic, 8) != 0) throw fail("not an mcpt checkpoint");
    uint32_t format = 0, text_size = 0;
    take(&format, 4);
    if (format != kFormat)
        throw fail("format " + std::to_string(format) + ", this mcpt reads format " +
                   std::to_string(kFormat));
    take(&text_size, 4);
    if (text_size > kMaxFingerprintBytes)
        throw fail("corrupted (a fingerprint of " + std::to_string(text_size) + " bytes)");
    std::string text(text_size, '\0');
    take(text.data(), text_size);
    const Fingerprint saved = decode_fingerprint(text);
    if (written) *written = saved;
    // What it was written for, key by key (the version first).
    for (size_t i = 0; expected && i < expected->size(); ++i) {
        const auto& [key, now] = (*expected)[i];
        std::string was = "(missing)";
        for (const auto& [k, v] : saved)
            if (k == key) was = v;
        if (was != now) throw fail(difference(key, was, now));
    }
    // The sums' header; the arrays' size it implies must be what the file holds.
    uint32_t width = 0, height = 0, exact = 0;
    uint64_t spp = 0, nonfinite_total = 0, first = 0;
    RenderResult r;
    take(&width, 4), take(&height, 4), take(&spp, 8), take(&nonfinite_total, 8);
    take(&r.rays, 8), take(&r.seconds, 8), take(&first, 8), take(&exact, 4);
    if (exact > 1) throw fail("corrupted (sums kind " + std::to_string(exact) + ")");
    if (width == 0 || height == 0 || width > 16384 || height > 16384)
        throw fail("corrupted (image size " + std::to_string(width) + "x" + std::to_string(height) +
                   ")");
    if (first > UINT64_MAX - spp) throw fail("corrupted (samples past 2^64)");
    const uint64_t n = uint64_t(width) * height;
    const uint64_t arrays = 7 * n * sizeof(double) + exact * 6 * n * sizeof(ExactSum);
    if (size - at < arrays + 8) throw fail("truncated");
    if (size - at > arrays + 8)
        throw fail("corrupted (" + std::to_string(size - at - arrays - 8) +
                   " bytes after its end)");
    r.width = int(width), r.height = int(height), r.spp = spp, r.first = first;
    r.nonfinite_total = nonfinite_total;
    if (header_only) return r;
    if (arrays > host_memory_available())
        throw fail("its sums need " + human_bytes(arrays) + ", " +
                   human_bytes(host_memory_available()) + " of memory are available");
    r.sum.resize(3 * n), r.sum_sq.resize(3 * n), r.nonfinite.resize(n);
    take(r.sum.data(), 3 * n * sizeof(double));
    take(r.sum_sq.data(), 3 * n * sizeof(double));
    take(r.nonfinite.data(), n * sizeof(double));
    r.exact.resize(exact * 6 * n);
    take(r.exact.data(), r.exact.size() * sizeof(ExactSum));
    const uint64_t computed = hash;
    uint64_t checksum = 0;
    take(&checksum, 8);
    if (checksum != computed) throw fail("corrupted (checksum mismatch)");
    return r;
}

RenderResult read_checkpoint_file(const std::string& path, const Fingerprint* expected,
                                  Fingerprint* written, bool header_only) {
    std::error_code ec;
    if (!std::filesystem::is_regular_file(path, ec))
        throw Error("checkpoint '" + path + "' refused: not a regular file");
    const uint64_t size = std::filesystem::file_size(path, ec);
    std::ifstream f(path, std::ios::binary);
    if (ec || !f) throw Error("checkpoint '" + path + "' refused: cannot read it");
    return parse(f, size, path, expected, written, header_only);
}

}  // namespace

RenderResult read_checkpoint(const std::string& path, const Fingerprint& expected) {
    return read_checkpoint_file(path, &expected, nullptr, false);
}

RenderResult read_checkpoint(const std::string& path, Fingerprint& written) {
    return read_checkpoint_file(path, nullptr, &written, false);
}

RenderResult read_checkpoint_header(const std::string& path, Fingerprint& written) {
    return read_checkpoint_file(path, nullptr, &written, true);
}

RenderResult read_checkpoint_memory(const void* data, size_t size, Fingerprint& written) {
    std::istringstream in(std::string(static_cast<const char*>(data), size));
    return parse(in, size, "(memory)", nullptr, &written, false);
}

}  // namespace mcpt
