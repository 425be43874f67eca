// `compare --report DIR` and `converge --report DIR`: a self-contained DIR/index.html with the
// verdicts and tables, every image a PNG data URI of the render's size, no URL to fetch; a
// biased B says DIFFER where an unbiased pair says AGREE; an unwritable folder is an error.
// Plus the report builder's own pieces (escaping, base64).
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>

#include <stb_image.h>

#include "common/io/html_report.h"
#include "test_util.h"

namespace mcpt {
namespace {

namespace fs = std::filesystem;

fs::path temp(const std::string& name) {
    return fs::temp_directory_path() / ("mcpt_report_" + name);
}

// Standard base64 back to bytes (the test's own decoder); false on a bad character.
bool base64_decode(const std::string& text, std::vector<unsigned char>& out) {
    uint32_t group = 0;
    int bits = 0;
    for (const char c : text) {
        int v;
        if (c >= 'A' && c <= 'Z')
            v = c - 'A';
        else if (c >= 'a' && c <= 'z')
            v = c - 'a' + 26;
        else if (c >= '0' && c <= '9')
            v = c - '0' + 52;
        else if (c == '+')
            v = 62;
        else if (c == '/')
            v = 63;
        else if (c == '=')
            break;
        else
            return false;
        group = (group << 6) | uint32_t(v), bits += 6;
        if (bits >= 8) bits -= 8, out.push_back(uint8_t(group >> bits));
    }
    return true;
}

uint32_t big_endian(const unsigned char* p) {
    return uint32_t(p[0]) << 24 | uint32_t(p[1]) << 16 | uint32_t(p[2]) << 8 | p[3];
}

// Every <img> of `html` is a PNG data URI of width x height; returns how many there are.
int check_images(const std::string& html, int width, int height) {
    int n = 0;
    for (size_t at = html.find("<img "); at != std::string::npos; at = html.find("<img ", at + 1)) {
        ++n;
        const std::string prefix = "src=\"data:image/png;base64,";
        const size_t src = html.find(prefix, at);
        EXPECT_EQ(src, html.find("src=", at)) << "image " << n << " is not a PNG data URI";
        if (src == std::string::npos) continue;
        const size_t begin = src + prefix.size(), end = html.find('"', begin);
        std::vector<unsigned char> png;
        EXPECT_TRUE(base64_decode(html.substr(begin, end - begin), png)) << "image " << n;
        // The 8-byte signature, then the IHDR chunk: length, "IHDR", width, height.
        static const unsigned char signature[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
        EXPECT_TRUE(png.size() > 24 && std::equal(signature, signature + 8, png.begin()))
            << "image " << n << " is no PNG";
        if (png.size() <= 24) continue;
        EXPECT_EQ(std::string(png.begin() + 12, png.begin() + 16), "IHDR") << "image " << n;
        EXPECT_EQ(big_endian(&png[16]), uint32_t(width)) << "image " << n;
        EXPECT_EQ(big_endian(&png[20]), uint32_t(height)) << "image " << n;
    }
    return n;
}

// The <img>s of `html` decoded (stb_image, not the project's writer): RGB, 8 bits.
struct Decoded {
    int width = 0, height = 0;
    std::vector<unsigned char> rgb;
    // Mean of channel c over the columns [x0, x1) of the middle half of the rows.
    double mean(int c, int x0, int x1) const {
        double sum = 0;
        int n = 0;
        for (int y = height / 4; y < 3 * height / 4; ++y)
            for (int x = x0; x < x1; ++x) sum += rgb[3 * size_t(y * width + x) + size_t(c)], ++n;
        return n ? sum / n : 0;
    }
    // Share of pixels whose colour passes `test(r, g, b)`.
    template <class Test>
    double share(Test test) const {
        size_t n = 0;
        for (size_t i = 0; i + 2 < rgb.size(); i += 3) n += test(rgb[i], rgb[i + 1], rgb[i + 2]);
        return double(n) / double(rgb.size() / 3);
    }
};
std::vector<Decoded> decode_images(const std::string& html) {
    std::vector<Decoded> out;
    const std::string prefix = "src=\"data:image/png;base64,";
    for (size_t at = html.find(prefix); at != std::string::npos; at = html.find(prefix, at + 1)) {
        const size_t begin = at + prefix.size(), end = html.find('"', begin);
        std::vector<unsigned char> png;
        if (!base64_decode(html.substr(begin, end - begin), png)) continue;
        Decoded d;
        int channels = 0;
        unsigned char* px =
            stbi_load_from_memory(png.data(), int(png.size()), &d.width, &d.height, &channels, 3);
        if (!px) continue;
        d.rgb.assign(px, px + size_t(d.width) * size_t(d.height) * 3);
        stbi_image_free(px);
        out.push_back(std::move(d));
    }
    return out;
}

// What compare's five images show: the Welch z map, A and B (the Cornell box: red wall left,
// green right; B brighter by `b_brighter`), the same-seed relative map and its z. Unbiased:
// z maps near white, relative map dark. B 20% brighter: z maps red (B brighter), relative map
// bright. Swapped, blank or mis-ordered images fail.
void expect_compare_images(const std::string& html, bool biased) {
    const std::vector<Decoded> img = decode_images(html);
    ASSERT_EQ(img.size(), 5u);
    // The z maps: white at 0, red where B is brighter, blue where darker: their mean of R - B
    // is about 0 where the sides agree, clearly positive where B is brighter.
    for (int k : {0, 4}) {
        const Decoded& d = img[k];
        double red_minus_blue = 0;
        for (size_t i = 0; i + 2 < d.rgb.size(); i += 3)
            red_minus_blue += double(d.rgb[i]) - double(d.rgb[i + 2]);
        red_minus_blue /= double(d.rgb.size() / 3);
        std::printf("image %d (z map): mean R - B %.1f\n", k, red_minus_blue);
        if (biased)
            EXPECT_GT(red_minus_blue, 10) << "image " << k << ": B 20% brighter, the z map not red";
        else
            EXPECT_LT(std::abs(red_minus_blue), 8) << "image " << k << ": agreeing sides, a z map not white";
    }
    for (int k : {1, 2}) {
        const Decoded& d = img[k];
        const int w = d.width;
        // Red wall on the left (R over G), green on the right (G over R), not blank.
        EXPECT_GT(d.mean(0, w / 32, 6 * w / 32), d.mean(1, w / 32, 6 * w / 32) + 40)
            << "image " << k << ": left wall";
        EXPECT_GT(d.mean(1, 26 * w / 32, 31 * w / 32), d.mean(0, 26 * w / 32, 31 * w / 32) + 15)
            << "image " << k << ": right wall";
    }
    // B brighter than A where biased; about as bright otherwise (sRGB of 1.2x: ~1.08x).
    const double a = img[1].mean(0, 0, img[1].width) + img[1].mean(1, 0, img[1].width);
    const double b = img[2].mean(0, 0, img[2].width) + img[2].mean(1, 0, img[2].width);
    std::printf("A %.1f, B %.1f (sRGB, R + G)\n", a, b);
    if (biased)
        EXPECT_GT(b, 1.04 * a);
    else
        EXPECT_NEAR(b / a, 1.0, 0.01);
    const double dark = img[3].share([](int r, int g, int b) { return std::max({r, g, b}) < 100; });
    std::printf("image 3 (relative): %.0f%% dark\n", 100 * dark);
    // (Same seed, the two drivers part by ~1e-5 relative where the light's solid-angle
    // sampling takes their sin and cos, which round differently: a quarter of the pixels show
    // it, all far under the 1e-3 that counts as diverged.)
    if (biased)
        EXPECT_LT(dark, 0.2) << "image 3: a 20% difference is not bright in the relative map";
    else
        EXPECT_GT(dark, 0.6) << "image 3: same-seed agreement is not dark in the relative map";
}

// Nothing that a browser would fetch, and no script.
void expect_self_contained(const std::string& html) {
    EXPECT_EQ(html.find("http://"), std::string::npos);
    EXPECT_EQ(html.find("https://"), std::string::npos);
    EXPECT_EQ(html.find("src=\"//"), std::string::npos);
    EXPECT_EQ(html.find("<script"), std::string::npos);
    EXPECT_EQ(html.find("<link"), std::string::npos);
}

// The text of the overall verdict line (id="overall").
std::string overall(const std::string& html) {
    const size_t at = html.find("id=\"overall\"");
    if (at == std::string::npos) return "";
    return html.substr(at, html.find("</p>", at) - at);
}

// compare on the test devices (OpenCL A, Vulkan B), small; its status, output and report.
struct CompareRun {
    test::CliRun cli;
    std::string html;
};

CompareRun compare_with_report(const std::string& name, const std::string& extra) {
    const std::string dev = test::device_args("opencl");
    const char* vk = std::getenv("MCPT_TEST_VULKAN_DEVICE");
    const fs::path dir = temp(name);
    fs::remove_all(dir);
    CompareRun r;
    r.cli = test::run_mcpt("compare cornell --a opencl:" + dev.substr(dev.rfind(' ') + 1) +
                           " --b vulkan" + (vk ? ":" + std::string(vk) : "") +
                           " --width 32 --height 32 --batches 8 --spp 4 --report " + dir.string() +
                           " " + extra);
    r.html = test::read_file((dir / "index.html").string());
    return r;
}

TEST(ReportHtml, EscapesTextAndEncodesBase64) {
    EXPECT_EQ(html_escape("<a href=\"x\">&'</a>"),
              "&lt;a href=&quot;x&quot;&gt;&amp;&#39;&lt;/a&gt;");
    // RFC 4648's test vectors.
    const std::pair<const char*, const char*> vectors[] = {{"", ""},
                                                           {"f", "Zg=="},
                                                           {"fo", "Zm8="},
                                                           {"foo", "Zm9v"},
                                                           {"foob", "Zm9vYg=="},
                                                           {"fooba", "Zm9vYmE="},
                                                           {"foobar", "Zm9vYmFy"}};
    for (const auto& [in, out] : vectors)
        EXPECT_EQ(base64_encode(std::vector<unsigned char>(in, in + std::strlen(in))), out) << in;
    std::vector<unsigned char> all(256), back;
    for (int i = 0; i < 256; ++i) all[i] = uint8_t(i);
    ASSERT_TRUE(base64_decode(base64_encode(all), back));
    EXPECT_EQ(back, all);
}

TEST(ReportHtml, BuilderWritesOneSelfContainedPage) {
    HtmlReport r("a <title>");
    r.verdict("PASS", true, "x & y", "overall");
    r.table({"h"}, {{"<cell>"}});
    r.images({{3, 2, std::vector<uint8_t>(18, 128), "grey"}});
    SvgPlot plot;
    plot.series.push_back({"s", {1, 10}, {1, 0.1}, "", false, true});
    r.plot(plot);
    const fs::path dir = temp("builder") / "nested";
    fs::remove_all(dir.parent_path());
    r.write(dir.string());
    const std::string html = test::read_file((dir / "index.html").string());
    EXPECT_NE(html.find("<title>a &lt;title&gt;</title>"), std::string::npos) << html;
    EXPECT_NE(html.find("<td>&lt;cell&gt;</td>"), std::string::npos);
    EXPECT_NE(overall(html).find("PASS</strong>: x &amp; y"), std::string::npos);
    EXPECT_NE(html.find("<svg"), std::string::npos);
    EXPECT_EQ(check_images(html, 3, 2), 1);
    expect_self_contained(html);
}

TEST(ReportCompare, UnbiasedPairAgrees) {
    const CompareRun r = compare_with_report("compare_agree", "");
    ASSERT_EQ(r.cli.status, 0) << r.cli.output;
    EXPECT_NE(r.cli.output.find("/index.html"), std::string::npos) << r.cli.output;
    EXPECT_NE(overall(r.html).find("AGREE"), std::string::npos) << overall(r.html);
    EXPECT_EQ(overall(r.html).find("DIFFER"), std::string::npos) << overall(r.html);
    // The speed table's rows, both verdicts, five images of the render's size.
    for (const char* s :
         {"<table>", "<td>M samples/s</td>", "<td>time per sample (ns)</td>", "<td>k-d tree</td>",
          "speed ratio B/A", "Statistical agreement", "Same seed", "pixels diverged"})
        EXPECT_NE(r.html.find(s), std::string::npos) << s;
    EXPECT_EQ(check_images(r.html, 32, 32), 5);
    expect_compare_images(r.html, false);
    expect_self_contained(r.html);
}

TEST(ReportCompare, BiasedBDiffersAndStillWritesTheReport) {
    // The negative control: exit status 2, and the report says so.
    const CompareRun r = compare_with_report("compare_differ", "--b-light-scale 1.2");
    ASSERT_EQ(r.cli.status, 2) << r.cli.output;
    EXPECT_NE(overall(r.html).find("DIFFER"), std::string::npos) << overall(r.html);
    EXPECT_NE(r.html.find("class=\"verdict fail\""), std::string::npos);
    EXPECT_EQ(check_images(r.html, 32, 32), 5);
    expect_compare_images(r.html, true);
    expect_self_contained(r.html);
}

// converge's report of `max_depth` bounces on the furnace (exact: infinitely many), stopped at
// 512 spp whatever the machine's speed.
std::string converge_report(const std::string& name, int max_depth) {
    const fs::path dir = temp(name);
    fs::remove_all(dir);
    fs::create_directories(dir);
    const test::CliRun r = test::run_mcpt(
        "converge furnace --width 32 --height 32 --time 60 --spp 512 --max-depth " +
        std::to_string(max_depth) + " --backend opencl:" + test::test_opencl_device() + " -o " +
        (dir / "c").string() + " --report " + (dir / "report").string());
    EXPECT_EQ(r.status, 0) << r.output;
    // The files it always wrote are still there.
    EXPECT_TRUE(fs::exists(dir / "c.csv"));
    EXPECT_TRUE(fs::exists(dir / "c.svg"));
    return test::read_file((dir / "report" / "index.html").string());
}

TEST(ReportConverge, FurnacePlotTablesAndImages) {
    const std::string html = converge_report("converge", 64);
    EXPECT_NE(overall(html).find("CONSISTENT"), std::string::npos) << overall(html);
    for (const char* s : {"<svg", "ideal slope -1/2", "Fits and bias", "consistent: slope vs spp",
                          "Time to a relative RMSE", "<td>10%</td>", "<td>5%</td>",
                          "<th>rel rmse</th>", "exact: Le/(1-rho) = 2"})
        EXPECT_NE(html.find(s), std::string::npos) << s;
    EXPECT_EQ(check_images(html, 32, 32), 2);  // the final image and its error map
    // The final image: the furnace's uniform radiance 2 (sRGB at the report's exposure: one
    // grey, not blank); the error map dark (the error below 10% nearly everywhere).
    const std::vector<Decoded> img = decode_images(html);
    ASSERT_EQ(img.size(), 2u);
    const double grey = img[0].mean(0, 0, 32);
    EXPECT_GT(grey, 60);
    EXPECT_NEAR(img[0].mean(1, 0, 32), grey, 3);
    EXPECT_GT(img[1].share([](int r, int g, int b) { return std::max({r, g, b}) < 160; }), 0.9);
    expect_self_contained(html);
}

// Control: 2 bounces where the exact radiance needs them all (a bias of -1/8 relative) is
// reported BIASED, in the title and the verdict.
TEST(ReportConverge, TruncatedPathsAreReportedBiased) {
    const std::string html = converge_report("converge_biased", 2);
    EXPECT_NE(overall(html).find("BIASED"), std::string::npos) << overall(html);
    EXPECT_NE(html.find("<title>mcpt converge furnace: BIASED</title>"), std::string::npos);
}

TEST(ReportCli, UnwritableFolderFailsBeforeRendering) {
    // A folder under a regular file cannot be made: a clear error, exit status 1.
    const fs::path file = temp("plain_file");
    fs::remove_all(file);
    { std::ofstream(file) << "x"; }
    const std::string dir = (file / "report").string();
    const test::CliRun c = test::run_mcpt("compare --report " + dir);
    EXPECT_EQ(c.status, 1) << c.output;
    EXPECT_NE(c.output.find("cannot create the report folder '" + dir + "'"), std::string::npos)
        << c.output;
    EXPECT_EQ(c.output.find("speed ratio"), std::string::npos) << "rendered first";
    const test::CliRun v = test::run_mcpt("converge furnace --time 1 --report " + dir);
    EXPECT_EQ(v.status, 1) << v.output;
    EXPECT_NE(v.output.find("cannot create the report folder"), std::string::npos) << v.output;
}

}  // namespace
}  // namespace mcpt
