// Checkpoint files and `merge` against hostile input: a file is read header first and then
// exactly the arrays its header implies (a sparse 40 GB file is refused at once, not read);
// a part whose range wraps past 2^64 or ends past its job, or whose fingerprint lacks a key
// the others have, is refused; parts merge one at a time into the same sums.
#include <gtest/gtest.h>

#include <chrono>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iterator>

#include "common/error.h"
#include "common/render/checkpoint.h"
#include "common/render/parts.h"
#include "test_util.h"

namespace mcpt {
namespace {

namespace fs = std::filesystem;

fs::path temp(const std::string& name) {
    return test::temp_file(name);
}

std::string error_of(const std::function<void()>& f) {
    try {
        f();
    } catch (const Error& e) {
        return e.what();
    }
    return "";
}

// Sums of a w x h image holding samples [first, first + spp), each pixel's value its index.
RenderResult sums(int w, int h, uint64_t first, uint64_t spp) {
    RenderResult r;
    r.width = w, r.height = h, r.first = first, r.spp = spp;
    const size_t n = size_t(w) * size_t(h);
    r.sum.resize(3 * n), r.sum_sq.resize(3 * n), r.nonfinite.assign(n, 0.0);
    for (size_t i = 0; i < 3 * n; ++i)
        r.sum[i] = double(spp) * double(i), r.sum_sq[i] = double(spp) * double(i) * double(i);
    r.rays = double(n * spp);
    return r;
}

Fingerprint job(const std::string& samples) {
    return {{"mcpt", "test"}, {"seed", "7"}, {"device", "cpu"}, {"samples", samples}};
}

std::string bytes_of(const fs::path& p) {
    std::ifstream f(p, std::ios::binary);
    return {std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>()};
}

TEST(CheckpointFile, RoundTripFromFileAndMemory) {
    const fs::path path = temp("round.ckpt");
    const RenderResult r = sums(5, 3, 0, 16);
    write_checkpoint(path.string(), job("all"), r);
    Fingerprint f;
    const RenderResult back = read_checkpoint(path.string(), f);
    EXPECT_EQ(f, job("all"));
    EXPECT_EQ(back.sum, r.sum);
    EXPECT_EQ(back.sum_sq, r.sum_sq);
    EXPECT_EQ(back.spp, 16u);
    const std::string bytes = bytes_of(path);
    Fingerprint g;
    EXPECT_EQ(read_checkpoint_memory(bytes.data(), bytes.size(), g).sum, r.sum);
    const RenderResult head = read_checkpoint_header(path.string(), g);
    EXPECT_TRUE(head.sum.empty());
    EXPECT_EQ(head.width, 5);
}

TEST(CheckpointFile, HostileFilesAreRefusedFromTheHeader) {
    // A sparse 40 GB file (no magic): refused without reading it (it was read whole first).
    const fs::path sparse = temp("sparse.ckpt");
    { std::ofstream(sparse, std::ios::binary) << ""; }
    fs::resize_file(sparse, uint64_t(40) << 30);
    const auto start = std::chrono::steady_clock::now();
    EXPECT_NE(error_of([&] {
                  read_checkpoint(sparse.string(), job("all"));
              }).find("not an mcpt checkpoint"),
              std::string::npos);
    EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(), 5.0);
    fs::remove(sparse);
    // A whole file with bytes after it, and one whose header announces a larger image.
    const fs::path path = temp("valid.ckpt");
    write_checkpoint(path.string(), job("all"), sums(4, 4, 0, 8));
    const std::string good = bytes_of(path);
    const auto read = [](const std::string& bytes) {
        return error_of([&] {
            Fingerprint f;
            read_checkpoint_memory(bytes.data(), bytes.size(), f);
        });
    };
    EXPECT_EQ(read(good), "");
    EXPECT_NE(read(good + "xx").find("2 bytes after its end"), std::string::npos);
    uint32_t text = 0;
    std::memcpy(&text, good.data() + 12, 4);
    std::string big = good;
    const uint32_t side = 16384;
    std::memcpy(&big[16 + text], &side, 4), std::memcpy(&big[20 + text], &side, 4);
    EXPECT_NE(read(big).find("truncated"), std::string::npos);
    std::string huge_text = good;
    const uint32_t lots = 1u << 30;
    std::memcpy(&huge_text[12], &lots, 4);
    EXPECT_NE(read(huge_text).find("a fingerprint of"), std::string::npos);
    EXPECT_NE(read(good.substr(0, 11)).find("truncated"), std::string::npos);
    // A flipped byte in the sums: the checksum.
    std::string flipped = good;
    flipped[good.size() - 20] ^= 1;
    EXPECT_NE(read(flipped).find("checksum"), std::string::npos);
}

TEST(CheckpointFile, MergeRefusesCraftedParts) {
    const fs::path a = temp("a.ckpt"), b = temp("b.ckpt"), out = temp("bad.ckpt");
    write_checkpoint(a.string(), job("0-64 of 128"), sums(4, 4, 0, 64));
    write_checkpoint(b.string(), job("64-128 of 128"), sums(4, 4, 64, 64));
    const auto merge = [&](const RenderResult& r, const Fingerprint& f) {
        write_checkpoint(out.string(), f, r);
        return error_of([&] { merge_parts({a.string(), out.string()}, true); });
    };
    // Samples that wrap past 2^64 back into the part's range.
    EXPECT_NE(merge(sums(4, 4, 64, ~uint64_t(0) - 40), job("64-128 of 128")).find("2^64"),
              std::string::npos);
    // More samples than the part's range.
    EXPECT_NE(merge(sums(4, 4, 64, 65), job("64-128 of 128")).find("outside its part"),
              std::string::npos);
    // A part that ends past its job, or is empty.
    EXPECT_NE(merge(sums(4, 4, 64, 64), job("64-256 of 128")).find("within its job"),
              std::string::npos);
    EXPECT_NE(merge(sums(4, 4, 64, 0), job("64-64 of 128")).find("within its job"),
              std::string::npos);
    // A key the first part has and this one lacks (was ignored), and the reverse.
    Fingerprint lacking = job("64-128 of 128");
    lacking.erase(lacking.begin() + 1);
    EXPECT_NE(merge(sums(4, 4, 64, 64), lacking).find("seed (missing) (there: 7)"),
              std::string::npos);
    Fingerprint extra = job("64-128 of 128");
    extra.emplace_back("env", "sky.exr");
    EXPECT_NE(merge(sums(4, 4, 64, 64), extra).find("env sky.exr"), std::string::npos);
    // Another image size.
    EXPECT_NE(merge(sums(4, 5, 64, 64), job("64-128 of 128")).find("4x5"), std::string::npos);
    // Control: the two parts of one job merge, as one image of their sums.
    const MergeResult m = merge_parts({b.string(), a.string()}, false);
    EXPECT_EQ(m.sums.spp, 128u);
    EXPECT_EQ(m.missing_spp, 0u);
    EXPECT_EQ(m.sums.sum, sums(4, 4, 0, 128).sum);
}

}  // namespace
}  // namespace mcpt
