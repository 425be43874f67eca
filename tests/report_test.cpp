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
    expect_self_contained(r.html);
}

TEST(ReportCompare, BiasedBDiffersAndStillWritesTheReport) {
    // The negative control: exit status 2, and the report says so.
    const CompareRun r = compare_with_report("compare_differ", "--b-light-scale 1.2");
    ASSERT_EQ(r.cli.status, 2) << r.cli.output;
    EXPECT_NE(overall(r.html).find("DIFFER"), std::string::npos) << overall(r.html);
    EXPECT_NE(r.html.find("class=\"verdict fail\""), std::string::npos);
    EXPECT_EQ(check_images(r.html, 32, 32), 5);
    expect_self_contained(r.html);
}

TEST(ReportConverge, FurnacePlotTablesAndImages) {
    const fs::path dir = temp("converge");
    fs::remove_all(dir);
    fs::create_directories(dir);
    const test::CliRun r =
        test::run_mcpt("converge furnace --width 32 --height 32 --time 1 --backend opencl:" +
                       test::test_opencl_device() + " -o " + (dir / "c").string() + " --report " +
                       (dir / "report").string());
    ASSERT_EQ(r.status, 0) << r.output;
    // The files it always wrote are still there.
    EXPECT_TRUE(fs::exists(dir / "c.csv"));
    EXPECT_TRUE(fs::exists(dir / "c.svg"));
    const std::string html = test::read_file((dir / "report" / "index.html").string());
    EXPECT_NE(overall(html).find("CONSISTENT"), std::string::npos) << overall(html);
    for (const char* s : {"<svg", "ideal slope -1/2", "Fits and bias", "consistent: slope vs spp",
                          "Time to a relative RMSE", "<td>10%</td>", "<td>5%</td>",
                          "<th>rel rmse</th>", "exact: Le/(1-rho) = 2"})
        EXPECT_NE(html.find(s), std::string::npos) << s;
    EXPECT_EQ(check_images(html, 32, 32), 2);  // the final image and its error map
    expect_self_contained(html);
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
