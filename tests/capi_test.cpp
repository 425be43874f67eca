// The C API (include/mcpt/mcpt.h): every misuse gets a status and a message, never a crash;
// loading from memory; passes with budgets, sample caps and target errors; cancel from
// another thread; reproducible images. Runs on both APIs' test devices.
#include <gtest/gtest.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include "mcpt/mcpt.h"
#include "test_util.h"

namespace {

std::vector<unsigned char> read_bytes(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

std::string data(const char* name) {
    return std::string(MCPT_TEST_DATA_DIR) + "/" + name;
}

// The C API's spec of a test API's device.
std::string spec_of(const std::string& api) {
    if (api == "opencl") return "opencl:" + mcpt::test::test_opencl_device();
    const char* e = std::getenv("MCPT_TEST_VULKAN_DEVICE");
    return e ? "vulkan:" + std::string(e) : "vulkan";
}

struct Session {
    mcpt_session s = nullptr;
    explicit Session(const std::string& spec) {
        EXPECT_EQ(mcpt_session_create(spec.c_str(), &s), MCPT_OK) << mcpt_last_error(nullptr);
    }
    ~Session() {
        if (s) mcpt_session_release(s);
    }
    std::string error() const { return mcpt_last_error(s); }
};

std::vector<float> rgba32f(mcpt_session s) {
    int w = 0, h = 0;
    EXPECT_EQ(mcpt_session_image_size(s, &w, &h), MCPT_OK);
    std::vector<float> px(size_t(4) * w * h);
    EXPECT_EQ(mcpt_session_read_rgba32f(s, px.data(), px.size()), MCPT_OK) << mcpt_last_error(s);
    return px;
}

}  // namespace

TEST(CApi, ListsDevices) {
    size_t n = 0;
    ASSERT_EQ(mcpt_devices(nullptr, 0, &n), MCPT_OK);
    ASSERT_GT(n, 0u);
    std::vector<mcpt_device_info> d(n);
    size_t again = 0;
    ASSERT_EQ(mcpt_devices(d.data(), d.size(), &again), MCPT_OK);
    EXPECT_EQ(again, n);
    for (const mcpt_device_info& i : d) {
        EXPECT_TRUE(std::string(i.api) == "opencl" || std::string(i.api) == "vulkan") << i.api;
        EXPECT_EQ(std::string(i.spec), std::string(i.api) + ":" + std::to_string(i.index));
        EXPECT_GT(std::strlen(i.name), 0u);
    }
    EXPECT_EQ(mcpt_devices(nullptr, 0, nullptr), MCPT_ERROR_INVALID_ARGUMENT);
    EXPECT_NE(std::string(mcpt_last_error(nullptr)).find("count is NULL"), std::string::npos);
    EXPECT_EQ(mcpt_devices(nullptr, 3, &n), MCPT_ERROR_INVALID_ARGUMENT);
}

// Every call with a NULL, released or made-up handle: MCPT_ERROR_INVALID_HANDLE and a message.
TEST(CApi, BadHandlesAreRefused) {
    mcpt_session released = nullptr;
    ASSERT_EQ(mcpt_session_create(spec_of("opencl").c_str(), &released), MCPT_OK);
    ASSERT_EQ(mcpt_session_release(released), MCPT_OK);
    const mcpt_session bad[] = {nullptr, released, reinterpret_cast<mcpt_session>(0x1234),
                                reinterpret_cast<mcpt_session>(&released)};
    for (mcpt_session s : bad) {
        float f[4];
        uint8_t b[4];
        int w, h;
        mcpt_device_info di;
        mcpt_scene_info si;
        mcpt_render_stats rs;
        const mcpt_status results[] = {
            mcpt_session_release(s),
            mcpt_session_device(s, &di),
            mcpt_session_load_file(s, "x.glb"),
            mcpt_session_load_memory(s, "x", 1, nullptr),
            mcpt_session_load_builtin(s, "cornell"),
            mcpt_session_scene_info(s, &si),
            mcpt_session_set_size(s, 8, 8),
            mcpt_session_set_max_bounces(s, 2),
            mcpt_session_set_tree(s, "sah", -1),
            mcpt_session_set_seed(s, 1),
            mcpt_session_set_specialize(s, 1),
            mcpt_session_set_reproducible(s, 1),
            mcpt_session_set_sampler(s, "sobol"),
            mcpt_session_set_adaptive(s, 1),
            mcpt_session_commit(s),
            mcpt_session_render(s, 10, 0, 0, &rs),
            mcpt_session_cancel(s),
            mcpt_session_reset(s),
            mcpt_session_image_size(s, &w, &h),
            mcpt_session_read_rgba32f(s, f, 4),
            mcpt_session_read_rgba8(s, b, 4),
            mcpt_session_write_image(s, "x.png"),
        };
        for (size_t i = 0; i < std::size(results); ++i) {
            EXPECT_EQ(results[i], MCPT_ERROR_INVALID_HANDLE) << "call " << i;
        }
        const std::string m = mcpt_last_error(s);
        EXPECT_NE(m.find(s ? "invalid session handle" : "NULL session handle"), std::string::npos)
            << m;
    }
    mcpt_session out = reinterpret_cast<mcpt_session>(0x99);
    EXPECT_EQ(mcpt_session_create("nonsense", &out), MCPT_ERROR_DEVICE);
    EXPECT_EQ(out, nullptr);
    EXPECT_NE(std::string(mcpt_last_error(nullptr)).find("unknown backend 'nonsense'"),
              std::string::npos);
    EXPECT_EQ(mcpt_session_create("opencl:no-such-device", &out), MCPT_ERROR_DEVICE);
    EXPECT_NE(std::string(mcpt_last_error(nullptr)).find("no OpenCL device matches"),
              std::string::npos);
    EXPECT_EQ(mcpt_session_create("opencl", nullptr), MCPT_ERROR_INVALID_ARGUMENT);
}

// Calls in the wrong order and bad arguments on a live session.
TEST(CApi, WrongOrderAndBadArguments) {
    Session s(spec_of("opencl"));
    mcpt_render_stats rs;
    int w, h;
    float f[4];
    mcpt_scene_info si;
    EXPECT_EQ(mcpt_session_render(s.s, 10, 0, 0, &rs), MCPT_ERROR_INVALID_STATE);
    EXPECT_NE(s.error().find("no scene loaded"), std::string::npos) << s.error();
    EXPECT_EQ(mcpt_session_commit(s.s), MCPT_ERROR_INVALID_STATE);
    EXPECT_EQ(mcpt_session_image_size(s.s, &w, &h), MCPT_ERROR_INVALID_STATE);
    EXPECT_EQ(mcpt_session_read_rgba32f(s.s, f, 4), MCPT_ERROR_INVALID_STATE);
    EXPECT_EQ(mcpt_session_write_image(s.s, "x.png"), MCPT_ERROR_INVALID_STATE);
    EXPECT_NE(s.error().find("nothing rendered yet"), std::string::npos) << s.error();
    ASSERT_EQ(mcpt_session_load_builtin(s.s, "cornell"), MCPT_OK);
    EXPECT_EQ(mcpt_session_scene_info(s.s, &si), MCPT_ERROR_INVALID_STATE);
    // Arguments.
    EXPECT_EQ(mcpt_session_set_size(s.s, 0, 8), MCPT_ERROR_INVALID_ARGUMENT);
    EXPECT_EQ(mcpt_session_set_size(s.s, 8, -1), MCPT_ERROR_INVALID_ARGUMENT);
    EXPECT_EQ(mcpt_session_set_size(s.s, 16385, 8), MCPT_ERROR_INVALID_ARGUMENT);
    EXPECT_NE(s.error().find("between 1x1 and 16384x16384"), std::string::npos) << s.error();
    EXPECT_EQ(mcpt_session_set_max_bounces(s.s, -2), MCPT_ERROR_INVALID_ARGUMENT);
    EXPECT_EQ(mcpt_session_set_tree(s.s, "octree", -1), MCPT_ERROR_INVALID_ARGUMENT);
    EXPECT_NE(s.error().find("unknown tree kind 'octree'"), std::string::npos) << s.error();
    EXPECT_EQ(mcpt_session_set_tree(s.s, "sah", 61), MCPT_ERROR_INVALID_ARGUMENT);
    EXPECT_EQ(mcpt_session_set_tree(s.s, nullptr, -1), MCPT_ERROR_INVALID_ARGUMENT);
    EXPECT_EQ(mcpt_session_set_sampler(s.s, "halton"), MCPT_ERROR_INVALID_ARGUMENT);
    EXPECT_NE(s.error().find("unknown sampler 'halton'"), std::string::npos) << s.error();
    EXPECT_EQ(mcpt_session_set_sampler(s.s, nullptr), MCPT_ERROR_INVALID_ARGUMENT);
    EXPECT_EQ(mcpt_session_render(s.s, NAN, 0, 0, &rs), MCPT_ERROR_INVALID_ARGUMENT);
    EXPECT_EQ(mcpt_session_render(s.s, -1, 0, 0, &rs), MCPT_ERROR_INVALID_ARGUMENT);
    EXPECT_EQ(mcpt_session_render(s.s, 10, INFINITY, 0, &rs), MCPT_ERROR_INVALID_ARGUMENT);
    EXPECT_EQ(mcpt_session_load_builtin(s.s, nullptr), MCPT_ERROR_INVALID_ARGUMENT);
    EXPECT_EQ(mcpt_session_load_file(s.s, ""), MCPT_ERROR_INVALID_ARGUMENT);
    // After a render: buffers too small, an unsupported image format.
    ASSERT_EQ(mcpt_session_set_size(s.s, 8, 8), MCPT_OK);
    ASSERT_EQ(mcpt_session_render(s.s, 0, 0, 1, &rs), MCPT_OK) << s.error();
    EXPECT_EQ(rs.spp, 1u);
    EXPECT_EQ(rs.relative_error, -1.0);  // unknown at one sample
    std::vector<float> small(4 * 64 - 1);
    EXPECT_EQ(mcpt_session_read_rgba32f(s.s, small.data(), small.size()),
              MCPT_ERROR_INVALID_ARGUMENT);
    EXPECT_NE(s.error().find("buffer too small"), std::string::npos) << s.error();
    EXPECT_EQ(mcpt_session_read_rgba8(s.s, nullptr, 1000), MCPT_ERROR_INVALID_ARGUMENT);
    EXPECT_EQ(mcpt_session_write_image(s.s, "image.bmp"), MCPT_ERROR_IO);
    EXPECT_EQ(mcpt_session_write_image(s.s, "/no/such/dir/image.png"), MCPT_ERROR_IO);
    // The session still works after all that, with either sampler.
    ASSERT_EQ(mcpt_session_render(s.s, 0, 0, 2, &rs), MCPT_OK) << s.error();
    EXPECT_EQ(rs.spp, 2u);
    ASSERT_EQ(mcpt_session_set_sampler(s.s, "independent"), MCPT_OK);
    ASSERT_EQ(mcpt_session_render(s.s, 0, 0, 2, &rs), MCPT_OK) << s.error();
    EXPECT_GE(rs.spp, 1u);  // a new image (one pass: no time budget)
    // Adaptive sampling on the device: past the warm-up to the mean asked for; not with
    // reproducible rendering, nor in a checkpoint.
    ASSERT_EQ(mcpt_session_set_adaptive(s.s, 1), MCPT_OK);
    EXPECT_EQ(mcpt_session_set_reproducible(s.s, 1), MCPT_ERROR_INVALID_ARGUMENT);
    EXPECT_NE(s.error().find("not reproducible"), std::string::npos) << s.error();
    ASSERT_EQ(mcpt_session_render(s.s, 1e6, 0, 48, &rs), MCPT_OK) << s.error();
    EXPECT_GE(rs.spp, 48u);
    EXPECT_GT(rs.relative_error, 0.0);
    EXPECT_EQ(mcpt_session_save_checkpoint(s.s, "adaptive.ckpt"), MCPT_ERROR_IO);
    EXPECT_NE(s.error().find("adaptive render"), std::string::npos) << s.error();
}

// An image beyond the host's memory is an error, not a crash; the session recovers.
TEST(CApi, ImageBeyondTheHost) {
    const uint64_t need = uint64_t(16384) * 16384 * mcpt::host_bytes_per_pixel();  // 23.6 GB
    if (need <= mcpt::host_memory_available() / 2) GTEST_SKIP() << "a host with room for it";
    for (const std::string& api : mcpt::test::test_apis()) {
        Session s(spec_of(api));
        ASSERT_EQ(mcpt_session_load_builtin(s.s, "cornell"), MCPT_OK);
        ASSERT_EQ(mcpt_session_set_size(s.s, 16384, 16384), MCPT_OK);
        EXPECT_EQ(mcpt_session_render(s.s, 10, 0, 1, nullptr), MCPT_ERROR_OUT_OF_MEMORY) << api;
        EXPECT_NE(s.error().find("image too large for this host: 16384x16384 needs 22 GiB"),
                  std::string::npos)
            << s.error();
        ASSERT_EQ(mcpt_session_set_size(s.s, 8, 8), MCPT_OK);
        EXPECT_EQ(mcpt_session_render(s.s, 10, 0, 1, nullptr), MCPT_OK) << s.error();
    }
}

// Bytes that are not a scene: empty, random, truncated, external files without a folder.
TEST(CApi, MalformedMemoryScenes) {
    Session s(spec_of("opencl"));
    EXPECT_EQ(mcpt_session_load_memory(s.s, nullptr, 0, nullptr), MCPT_ERROR_SCENE);
    EXPECT_NE(s.error().find("empty buffer"), std::string::npos) << s.error();
    EXPECT_EQ(mcpt_session_load_memory(s.s, nullptr, 5, nullptr), MCPT_ERROR_INVALID_ARGUMENT);
    std::mt19937 rng(5);
    for (int i = 0; i < 20; ++i) {
        std::vector<unsigned char> junk(1 + rng() % 4096);
        for (unsigned char& c : junk) c = static_cast<unsigned char>(rng());
        if (i % 2) std::memcpy(junk.data(), "glTF", std::min<size_t>(4, junk.size()));
        EXPECT_EQ(mcpt_session_load_memory(s.s, junk.data(), junk.size(), nullptr),
                  MCPT_ERROR_SCENE);
        EXPECT_NE(s.error().find("memory: cannot load"), std::string::npos) << s.error();
    }
    const std::vector<unsigned char> glb = read_bytes(data("cube_box.glb"));
    ASSERT_GT(glb.size(), 100u);
    for (size_t cut : {size_t(12), size_t(40), glb.size() / 2, glb.size() - 1}) {
        EXPECT_EQ(mcpt_session_load_memory(s.s, glb.data(), cut, nullptr), MCPT_ERROR_SCENE) << cut;
    }
    // A .gltf whose buffer is an external file: refused without a folder, read with one.
    const std::filesystem::path dir =
        std::filesystem::temp_directory_path() / ("mcpt_capi_" + std::to_string(getpid()));
    std::filesystem::create_directories(dir);
    const std::vector<unsigned char> text = read_bytes(data("emissive_triangle.gltf"));
    const std::string gltf(text.begin(), text.end());
    const size_t uri = gltf.find("\"uri\"");
    ASSERT_NE(uri, std::string::npos);
    const size_t start = gltf.find("data:", uri), end = gltf.find('"', start);
    ASSERT_NE(start, std::string::npos);
    const std::string payload = gltf.substr(start, end - start);
    const std::string external = gltf.substr(0, start) + "triangle.bin" + gltf.substr(end);
    {
        // The same buffer as a file: the data URI's base64 payload decoded.
        const std::string b64 = payload.substr(payload.find(',') + 1);
        std::string bin;
        uint32_t val = 0;
        int bits = -8;
        for (unsigned char c : b64) {
            const char* table = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
            const char* p = std::strchr(table, c);
            if (c == '=' || p == nullptr) break;
            val = (val << 6) + uint32_t(p - table), bits += 6;
            if (bits >= 0) bin.push_back(char((val >> bits) & 0xff)), bits -= 8;
        }
        std::ofstream(dir / "triangle.bin", std::ios::binary) << bin;
    }
    EXPECT_EQ(mcpt_session_load_memory(s.s, external.data(), external.size(), nullptr),
              MCPT_ERROR_SCENE);
    EXPECT_NE(s.error().find("external file 'triangle.bin' refused"), std::string::npos)
        << s.error();
    EXPECT_EQ(mcpt_session_load_memory(s.s, external.data(), external.size(), dir.string().c_str()),
              MCPT_OK)
        << s.error();
    std::filesystem::remove_all(dir);
    // Files and names that are not scenes.
    EXPECT_EQ(mcpt_session_load_file(s.s, "/no/such/scene.glb"), MCPT_ERROR_SCENE);
    EXPECT_NE(s.error().find("file not found"), std::string::npos) << s.error();
    EXPECT_EQ(mcpt_session_load_builtin(s.s, "teapot"), MCPT_ERROR_SCENE);
    EXPECT_NE(s.error().find("cornell"), std::string::npos) << s.error();
}

// A .glb from memory renders the very image the same file does (reproducible mode), and the
// session records the tree it chose and why.
TEST(CApi, MemoryEqualsFileAndRecordsTheTree) {
    const std::vector<unsigned char> glb = read_bytes(data("cube_box.glb"));
    std::vector<float> images[2];
    for (int k = 0; k < 2; ++k) {
        Session s(spec_of("opencl"));
        ASSERT_EQ(k == 0 ? mcpt_session_load_file(s.s, data("cube_box.glb").c_str())
                         : mcpt_session_load_memory(s.s, glb.data(), glb.size(), nullptr),
                  MCPT_OK)
            << s.error();
        ASSERT_EQ(mcpt_session_set_size(s.s, 24, 24), MCPT_OK);
        ASSERT_EQ(mcpt_session_set_reproducible(s.s, 1), MCPT_OK);
        ASSERT_EQ(mcpt_session_set_seed(s.s, 3), MCPT_OK);
        ASSERT_EQ(mcpt_session_render(s.s, 1e6, 0, 4, nullptr), MCPT_OK) << s.error();
        images[k] = rgba32f(s.s);
        mcpt_scene_info si;
        ASSERT_EQ(mcpt_session_scene_info(s.s, &si), MCPT_OK);
        EXPECT_EQ(si.triangles, 24u);
        EXPECT_EQ(si.max_bounces, 8);
        EXPECT_TRUE(std::string(si.tree) == "bvh" || std::string(si.tree) == "none") << si.tree;
        EXPECT_NE(std::string(si.tree_reason).find(si.tree), std::string::npos) << si.tree_reason;
    }
    EXPECT_EQ(images[0], images[1]);
}

// Reproducible mode: the image depends on the seed and the sample count only, not on the
// passes' budgets; another seed changes it (the test can fail).
TEST(CApi, ReproducibleAcrossBudgets) {
    for (const std::string& api : mcpt::test::test_apis()) {
        std::vector<float> img[3];
        const double budgets[3] = {0, 1e6, 0};
        for (int k = 0; k < 3; ++k) {
            Session s(spec_of(api));
            ASSERT_EQ(mcpt_session_load_builtin(s.s, "cornell"), MCPT_OK);
            ASSERT_EQ(mcpt_session_set_size(s.s, 16, 16), MCPT_OK);
            ASSERT_EQ(mcpt_session_set_reproducible(s.s, 1), MCPT_OK);
            ASSERT_EQ(mcpt_session_set_seed(s.s, k == 2 ? 8 : 7), MCPT_OK);
            // Budget 0: one pass per call, 6 calls; else one call.
            mcpt_render_stats st{};
            do {
                ASSERT_EQ(mcpt_session_render(s.s, budgets[k], 0, 6, &st), MCPT_OK);
            } while (st.spp < 6);
            EXPECT_EQ(st.spp, 6u);
            img[k] = rgba32f(s.s);
        }
        EXPECT_EQ(img[0], img[1]) << api;
        EXPECT_NE(img[0], img[2]) << api;
    }
}

// A reproducible render saved at 40 spp (the checkpoint holds the 32 of two whole groups) and
// resumed in a new session to 80 spp equals the render that ran 80 spp at once, bit for bit;
// a checkpoint for another seed is refused with a message naming it, and changes nothing.
TEST(CApi, CheckpointResumesBitForBit) {
    for (const std::string& api : mcpt::test::test_apis()) {
        const std::string path = ::testing::TempDir() + "capi_checkpoint_" + api + ".bin";
        auto open = [&](Session& s, uint32_t seed) {
            ASSERT_EQ(mcpt_session_load_builtin(s.s, "cornell"), MCPT_OK);
            ASSERT_EQ(mcpt_session_set_size(s.s, 16, 12), MCPT_OK);
            ASSERT_EQ(mcpt_session_set_reproducible(s.s, 1), MCPT_OK);
            ASSERT_EQ(mcpt_session_set_seed(s.s, seed), MCPT_OK);
        };
        auto render_to = [&](Session& s, uint64_t spp) {
            mcpt_render_stats st{};
            do {
                ASSERT_EQ(mcpt_session_render(s.s, 5, 0, spp, &st), MCPT_OK) << s.error();
            } while (st.spp < spp);
        };
        std::vector<float> whole, resumed;
        {
            Session s(spec_of(api));
            open(s, 3);
            render_to(s, 80);
            whole = rgba32f(s.s);
        }
        {
            Session s(spec_of(api));
            open(s, 3);
            render_to(s, 40);
            ASSERT_EQ(mcpt_session_save_checkpoint(s.s, path.c_str()), MCPT_OK) << s.error();
        }
        {
            Session s(spec_of(api));
            open(s, 4);
            EXPECT_EQ(mcpt_session_resume_checkpoint(s.s, path.c_str()), MCPT_ERROR_IO);
            EXPECT_NE(s.error().find("seed 3 (now 4)"), std::string::npos) << s.error();
            mcpt_render_stats st{};
            ASSERT_EQ(mcpt_session_render(s.s, 0, 0, 1, &st), MCPT_OK);
            EXPECT_EQ(st.spp, 1u) << "a refused checkpoint was mixed in";
        }
        {
            Session s(spec_of(api));
            open(s, 3);
            ASSERT_EQ(mcpt_session_resume_checkpoint(s.s, path.c_str()), MCPT_OK) << s.error();
            render_to(s, 80);
            resumed = rgba32f(s.s);
        }
        EXPECT_TRUE(whole == resumed) << api << ": the resumed render differs";
        std::remove(path.c_str());
    }
}

// Two sessions on one device, in two threads at once (each with its own scene, seed and
// size), give the images each gives alone, bit for bit (reproducible mode); the threads share
// nothing but the engine and the driver. Also run under ThreadSanitizer (scripts/test-tsan).
// One image on two devices (the same device twice, in threads of the engine's): the image of
// one device bit for bit in reproducible mode; bad arguments are refused.
TEST(CApi, SeveralDevicesOneImage) {
    for (const std::string& api : mcpt::test::test_apis()) {
        auto render = [&](size_t count, std::vector<float>& out) {
            const std::string spec = spec_of(api);
            const char* specs[2] = {spec.c_str(), spec.c_str()};
            mcpt_session s = nullptr;
            ASSERT_EQ(mcpt_session_create_devices(specs, count, &s), MCPT_OK)
                << mcpt_last_error(nullptr);
            ASSERT_EQ(mcpt_session_load_builtin(s, "cornell"), MCPT_OK);
            ASSERT_EQ(mcpt_session_set_size(s, 24, 20), MCPT_OK);
            ASSERT_EQ(mcpt_session_set_seed(s, 5), MCPT_OK);
            ASSERT_EQ(mcpt_session_set_reproducible(s, 1), MCPT_OK);
            mcpt_render_stats st{};
            while (st.spp < 64)
                ASSERT_EQ(mcpt_session_render(s, 50, 0, 64, &st), MCPT_OK) << mcpt_last_error(s);
            out.resize(size_t(4) * 24 * 20);
            ASSERT_EQ(mcpt_session_read_rgba32f(s, out.data(), out.size()), MCPT_OK);
            EXPECT_EQ(mcpt_session_release(s), MCPT_OK);
        };
        std::vector<float> one, two;
        render(1, one);
        render(2, two);
        EXPECT_FALSE(one.empty());
        EXPECT_TRUE(one == two) << api;
    }
    mcpt_session s = nullptr;
    const char* none[1] = {"opencl"};
    EXPECT_EQ(mcpt_session_create_devices(none, 0, &s), MCPT_ERROR_INVALID_ARGUMENT);
    EXPECT_EQ(mcpt_session_create_devices(nullptr, 2, &s), MCPT_ERROR_INVALID_ARGUMENT);
    const char* bad[2] = {"opencl", "vulkan:no such device"};
    EXPECT_EQ(mcpt_session_create_devices(bad, 2, &s), MCPT_ERROR_DEVICE);
    EXPECT_NE(std::string(mcpt_last_error(nullptr)).find("no such device"), std::string::npos);
    EXPECT_EQ(s, nullptr);
}

TEST(CApi, TwoSessionsInTwoThreads) {
    for (const std::string& api : mcpt::test::test_apis()) {
        struct Job {
            const char* scene;
            uint32_t seed;
            int width, height;
            std::vector<float> alone, together;
            std::string error;
        } jobs[2] = {{"cornell", 1, 20, 16, {}, {}, {}}, {"spheres", 2, 12, 18, {}, {}, {}}};
        auto run = [&](Job& j, std::vector<float>& out) {
            mcpt_session s = nullptr;
            if (mcpt_session_create(spec_of(api).c_str(), &s) != MCPT_OK) {
                j.error = mcpt_last_error(nullptr);
                return;
            }
            mcpt_render_stats st{};
            if (mcpt_session_load_builtin(s, j.scene) != MCPT_OK ||
                mcpt_session_set_size(s, j.width, j.height) != MCPT_OK ||
                mcpt_session_set_seed(s, j.seed) != MCPT_OK ||
                mcpt_session_set_reproducible(s, 1) != MCPT_OK)
                j.error = mcpt_last_error(s);
            while (j.error.empty() && st.spp < 40)
                if (mcpt_session_render(s, 2, 0, 40, &st) != MCPT_OK) j.error = mcpt_last_error(s);
            if (j.error.empty()) {
                out.resize(size_t(4) * j.width * j.height);
                if (mcpt_session_read_rgba32f(s, out.data(), out.size()) != MCPT_OK)
                    j.error = mcpt_last_error(s);
            }
            mcpt_session_release(s);
        };
        for (Job& j : jobs) run(j, j.alone);
        std::thread a([&] { run(jobs[0], jobs[0].together); });
        std::thread b([&] { run(jobs[1], jobs[1].together); });
        a.join(), b.join();
        for (const Job& j : jobs) {
            EXPECT_EQ(j.error, "") << api << " " << j.scene;
            EXPECT_FALSE(j.alone.empty()) << api << " " << j.scene;
            EXPECT_TRUE(j.alone == j.together) << api << " " << j.scene << ": differs in a thread";
        }
        EXPECT_FALSE(jobs[0].alone == jobs[1].alone);
    }
}

// A target error stops the render; the error reported is the image's.
TEST(CApi, StopsAtTargetError) {
    Session s(spec_of("opencl"));
    ASSERT_EQ(mcpt_session_load_builtin(s.s, "cornell"), MCPT_OK);
    ASSERT_EQ(mcpt_session_set_size(s.s, 32, 32), MCPT_OK);
    mcpt_render_stats st{};
    ASSERT_EQ(mcpt_session_render(s.s, 60000, 0.2, 0, &st), MCPT_OK) << s.error();
    EXPECT_EQ(st.target_reached, 1);
    EXPECT_GT(st.relative_error, 0);
    EXPECT_LE(st.relative_error, 0.2);
    EXPECT_LT(st.seconds, 30);
}

// Cancels `s` until the render on `thread` has ended (a cancel before the render starts does
// not count, and a busy machine may start the thread late); false after 20 s.
bool cancel_until_done(mcpt_session s, std::thread& thread, const std::atomic<bool>& done) {
    const auto t0 = std::chrono::steady_clock::now();
    while (!done.load()) {
        if (std::chrono::steady_clock::now() - t0 > std::chrono::seconds(20)) return false;
        EXPECT_EQ(mcpt_session_cancel(s), MCPT_OK);
        std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
    thread.join();
    return true;
}

// cancel() from another thread ends a long render after its pass; release() while another
// thread renders cancels and waits.
TEST(CApi, CancelAndReleaseFromAnotherThread) {
    for (const std::string& api : mcpt::test::test_apis()) {
        mcpt_session s = nullptr;
        ASSERT_EQ(mcpt_session_create(spec_of(api).c_str(), &s), MCPT_OK);
        ASSERT_EQ(mcpt_session_load_builtin(s, "cornell"), MCPT_OK);
        ASSERT_EQ(mcpt_session_set_size(s, 32, 32), MCPT_OK);
        ASSERT_EQ(mcpt_session_commit(s), MCPT_OK) << mcpt_last_error(s);
        mcpt_status status = MCPT_OK;
        mcpt_render_stats st{};
        std::atomic<bool> done{false};
        std::thread render([&] {
            status = mcpt_session_render(s, 120000, 0, 0, &st);
            done.store(true);
        });
        std::this_thread::sleep_for(std::chrono::milliseconds(300));
        ASSERT_TRUE(cancel_until_done(s, render, done)) << api << ": cancel did not end it";
        EXPECT_EQ(status, MCPT_CANCELLED) << api;
        EXPECT_GT(st.spp, 0u);
        EXPECT_EQ(rgba32f(s).size(), 4u * 32 * 32);
        // Release during a render on another thread.
        std::thread again([&] { status = mcpt_session_render(s, 120000, 0, 0, nullptr); });
        std::this_thread::sleep_for(std::chrono::milliseconds(300));
        EXPECT_EQ(mcpt_session_release(s), MCPT_OK);
        again.join();
        EXPECT_EQ(status, MCPT_CANCELLED) << api;
        EXPECT_EQ(mcpt_session_release(s), MCPT_ERROR_INVALID_HANDLE);
    }
}

// Lamps from a glTF file and an environment set through the C API: both lit, both compiled in
// only when used; bad environments refused with the reason.
TEST(CApi, LampsAndEnvironment) {
    for (const std::string& api : mcpt::test::test_apis()) {
        Session s(spec_of(api));
        ASSERT_EQ(mcpt_session_load_file(s.s, data("lamps.gltf").c_str()), MCPT_OK) << s.error();
        ASSERT_EQ(mcpt_session_set_size(s.s, 16, 16), MCPT_OK);
        ASSERT_EQ(mcpt_session_render(s.s, 0, 0, 4, nullptr), MCPT_OK) << s.error();
        mcpt_scene_info info{};
        ASSERT_EQ(mcpt_session_scene_info(s.s, &info), MCPT_OK);
        EXPECT_NE(std::string(info.features).find("punctual lights"), std::string::npos);
        EXPECT_EQ(std::string(info.features).find("environment"), std::string::npos);
        EXPECT_EQ(info.lights, 3u);
        // A background: one more light, and the environment's code.
        ASSERT_EQ(mcpt_session_set_background(s.s, 0.5f, 0.5f, 0.5f), MCPT_OK);
        ASSERT_EQ(mcpt_session_render(s.s, 0, 0, 4, nullptr), MCPT_OK) << s.error();
        ASSERT_EQ(mcpt_session_scene_info(s.s, &info), MCPT_OK);
        EXPECT_NE(std::string(info.features).find("environment"), std::string::npos);
        EXPECT_EQ(info.lights, 4u);
        // Refused, with the reason; the session keeps working.
        EXPECT_EQ(mcpt_session_set_environment(s.s, "/nonexistent.exr", 0, 1), MCPT_ERROR_SCENE);
        EXPECT_NE(s.error().find("not a readable regular file"), std::string::npos) << s.error();
        const char junk[] = "not an image";
        EXPECT_EQ(mcpt_session_set_environment_memory(s.s, junk, sizeof junk, 0, 1),
                  MCPT_ERROR_SCENE);
        EXPECT_NE(s.error().find("not an OpenEXR or Radiance"), std::string::npos) << s.error();
        EXPECT_EQ(mcpt_session_set_background(s.s, -1.f, 0.f, 0.f), MCPT_ERROR_INVALID_ARGUMENT);
        EXPECT_EQ(mcpt_session_set_environment(s.s, "x.exr", 0, -1), MCPT_ERROR_SCENE);
        EXPECT_EQ(mcpt_session_render(s.s, 0, 0, 8, nullptr), MCPT_OK) << s.error();
    }
}

// The 8-bit image is the sRGB encoding of the float image.
TEST(CApi, Rgba8IsSrgbOfRgba32f) {
    Session s(spec_of("opencl"));
    ASSERT_EQ(mcpt_session_load_builtin(s.s, "cornell"), MCPT_OK);
    ASSERT_EQ(mcpt_session_set_size(s.s, 16, 8), MCPT_OK);
    ASSERT_EQ(mcpt_session_render(s.s, 0, 0, 4, nullptr), MCPT_OK);
    const std::vector<float> f = rgba32f(s.s);
    std::vector<uint8_t> b(f.size());
    ASSERT_EQ(mcpt_session_read_rgba8(s.s, b.data(), b.size()), MCPT_OK);
    for (size_t i = 0; i < f.size(); ++i) {
        if (i % 4 == 3) {
            EXPECT_EQ(b[i], 255);
            EXPECT_EQ(f[i], 1.f);
            continue;
        }
        const double c = std::min(1.0, std::max(0.0, double(f[i])));
        const double srgb = c <= 0.0031308 ? 12.92 * c : 1.055 * std::pow(c, 1 / 2.4) - 0.055;
        EXPECT_NEAR(b[i], srgb * 255, 0.51) << i;
    }
}

// A device lost mid-render (injected: MCPT_LOSE_DEVICE_AFTER): MCPT_ERROR_DEVICE_LOST with a
// message, the samples taken before stay readable and writable, and the session renders no
// more.
TEST(CApi, DeviceLostKeepsTheImage) {
    for (const std::string& api : mcpt::test::test_apis()) {
        setenv("MCPT_LOSE_DEVICE_AFTER", "40", 1);
        Session s(spec_of(api));
        unsetenv("MCPT_LOSE_DEVICE_AFTER");
        ASSERT_EQ(mcpt_session_load_builtin(s.s, "cornell"), MCPT_OK);
        ASSERT_EQ(mcpt_session_set_size(s.s, 16, 16), MCPT_OK);
        mcpt_render_stats st{};
        mcpt_status status = MCPT_OK;
        uint64_t spp_before = 0;
        for (int call = 0; call < 1000 && status == MCPT_OK; ++call) {
            status = mcpt_session_render(s.s, 20, 0, 0, &st);
            if (status == MCPT_OK) spp_before = st.spp;
        }
        ASSERT_EQ(status, MCPT_ERROR_DEVICE_LOST) << api << ": " << s.error();
        EXPECT_NE(s.error().find("lose_device_after"), std::string::npos) << s.error();
        // Every sample of the calls before is in the image, none of the failed call's.
        const std::vector<float> px = rgba32f(s.s);
        ASSERT_GT(spp_before, 0u) << api;
        double sum = 0;
        for (float v : px) sum += v;
        EXPECT_GT(sum, double(px.size() / 4)) << api;  // radiance beyond the alphas of 1
        const std::string out = testing::TempDir() + "/lost_" + api + ".exr";
        EXPECT_EQ(mcpt_session_write_image(s.s, out.c_str()), MCPT_OK) << s.error();
        EXPECT_GT(std::filesystem::file_size(out), 0u);
        EXPECT_EQ(mcpt_session_render(s.s, 20, 0, 0, &st), MCPT_ERROR_DEVICE_LOST) << api;
        EXPECT_NE(s.error().find("open a new session"), std::string::npos) << s.error();
    }
}
