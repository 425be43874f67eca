// mcpt bench: `mcpt bench --quick` through the binary prints a Markdown table with a row for
// every scene x tree x backend and writes the table, a CSV and a log-log SVG plot.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "common/io/svg_plot.h"
#include "test_util.h"

namespace mcpt {
namespace {

using test::CliRun;
using test::run_mcpt;

std::string read_file(const std::filesystem::path& p) {
    std::ifstream f(p);
    std::stringstream s;
    s << f.rdbuf();
    return s.str();
}

// A CSV line's cells (a quoted cell may hold commas: a device's name).
std::vector<std::string> csv_cells(const std::string& line) {
    std::vector<std::string> cells;
    std::string cell;
    bool quoted = false;
    for (char ch : line) {
        if (ch == '"')
            quoted = !quoted;
        else if (ch == ',' && !quoted)
            cells.push_back(cell), cell.clear();
        else
            cell += ch;
    }
    cells.push_back(cell);
    return cells;
}

TEST(BenchCli, QuickTableHasEveryRow) {
    // No models: the built-in Cornell box and the generated mesh, on the test device.
    const auto dir = std::filesystem::temp_directory_path() / "mcpt_bench_test";
    std::filesystem::remove_all(dir);
    std::filesystem::create_directories(dir / "no-models");
    const std::string prefix = (dir / "quick").string();
    const CliRun r = run_mcpt("bench --quick --frames 1 --models " + (dir / "no-models").string() +
                              " --backend opencl:" + test::test_opencl_device() + " -o " + prefix);
    ASSERT_EQ(r.status, 0) << r.output;
    EXPECT_NE(
        r.output.find("| model | triangles | tree | backend/device | build ms | tree bytes "
                      "| ms/frame | M samples/s | Mrays/s | tri tests/ray | node visits/ray |"),
        std::string::npos)
        << r.output;
    for (const char* model : {"cornell", "generated-sphere"}) {
        for (const char* tree : {"none", "median-3", "sah", "bvh"}) {
            const std::string head = std::string("| ") + model + " | ";
            const std::string tree_cell = std::string(" | ") + tree + " | opencl: ";
            size_t rows = 0;
            std::istringstream lines(r.output);
            for (std::string line; std::getline(lines, line);) {
                if (line.rfind(head, 0) != 0 || line.find(tree_cell) == std::string::npos) continue;
                ++rows;
                EXPECT_EQ(line.find("skipped"), std::string::npos) << line;
                // 11 cells: 12 bars.
                EXPECT_EQ(std::count(line.begin(), line.end(), '|'), 12) << line;
            }
            EXPECT_EQ(rows, 1u) << model << " " << tree << "\n" << r.output;
        }
    }
    // The files: the same table, one CSV line per row, an SVG with a curve per tree.
    EXPECT_NE(read_file(prefix + ".md").find("| cornell | 12 | sah |"), std::string::npos);
    const std::string csv = read_file(prefix + ".csv");
    EXPECT_EQ(std::count(csv.begin(), csv.end(), '\n'), 9) << csv;
    const std::string svg = read_file(prefix + ".svg");
    EXPECT_EQ(svg.rfind("<svg", 0), 0u);
    EXPECT_EQ(std::count(svg.begin(), svg.end(), '\n') > 10, true);
    for (const char* tree : {"none @ opencl", "median-3 @ opencl", "sah @ opencl", "bvh @ opencl"})
        EXPECT_NE(svg.find(tree), std::string::npos) << tree;
}

TEST(BenchCli, SpecializeTableHasEveryScene) {
    const auto dir = std::filesystem::temp_directory_path() / "mcpt_bench_specialize_test";
    std::filesystem::remove_all(dir);
    std::filesystem::create_directories(dir / "no-models");
    const std::string prefix = (dir / "spec").string();
    const CliRun r =
        run_mcpt("bench --specialize --quick --frames 1 --models " + (dir / "no-models").string() +
                 " --backend opencl:" + test::test_opencl_device() + " -o " + prefix);
    ASSERT_EQ(r.status, 0) << r.output;
    const std::string kMaterialBits =
        "microfacet, shading normals, textures, alpha mask, punctual lights, environment, "
        "light tree, wide BVH, lights by contribution, volume, clearcoat, sheen";
    const std::string expected[][2] = {
        {"walls only (diffuse mesh)",
         "spheres, mirror, glass, triangle lights, sphere lights, " + kMaterialBits},
        {"cornell", "triangle lights, sphere lights, " + kMaterialBits},
        {"spheres",
         "triangles, triangle lights, k-d tree, " + kMaterialBits + ", rectangle lights"}};
    for (const auto& [scene, left_out] : expected) {
        const std::string head = std::string("| ") + scene + " | opencl: ";
        const size_t at = r.output.find(head);
        ASSERT_NE(at, std::string::npos) << scene << "\n" << r.output;
        const std::string line = r.output.substr(at, r.output.find('\n', at) - at);
        EXPECT_NE(line.find(std::string(" | ") + left_out + " | "), std::string::npos) << line;
        // 10 cells: 11 bars; every time and speed-up filled in.
        EXPECT_EQ(std::count(line.begin(), line.end(), '|'), 11) << line;
        EXPECT_EQ(line.find("| - |"), std::string::npos) << line;
    }
    const std::string csv = read_file(prefix + ".csv");
    EXPECT_EQ(std::count(csv.begin(), csv.end(), '\n'), 4) << csv;
}

// The scaling table in one command: --devices 1,2 gives each scene a row on one device and
// one on two (here PoCL twice), the second with its speed-up over the first.
TEST(BenchCli, ThroughputRowsPerDeviceCount) {
    const auto dir = std::filesystem::temp_directory_path() / "mcpt_bench_devices_test";
    std::filesystem::remove_all(dir);
    std::filesystem::create_directories(dir / "no-models");
    const std::string prefix = (dir / "tp").string();
    const std::string d = " --backend opencl:" + test::test_opencl_device();
    const CliRun r = run_mcpt(
        "bench --throughput --quick --tree sah --time 0.2 --devices 1,2 "
        "--models " +
        (dir / "no-models").string() + d + d + " -o " + prefix);
    ASSERT_EQ(r.status, 0) << r.output;
    std::istringstream lines(read_file(prefix + ".csv"));
    std::string line;
    std::getline(lines, line);
    EXPECT_NE(line.find(",devices,speedup,"), std::string::npos) << line;
    // The devices and speed-up columns, found by the header's names.
    const std::vector<std::string> header = csv_cells(line);
    const auto column = [&](const char* name) {
        return size_t(std::find(header.begin(), header.end(), name) - header.begin());
    };
    const size_t devices_at = column("devices"), speedup_at = column("speedup");
    ASSERT_LT(speedup_at, header.size()) << line;
    std::vector<std::pair<int, double>> rows;  // devices, speed-up
    for (; std::getline(lines, line);) {
        const std::vector<std::string> cells = csv_cells(line);
        ASSERT_EQ(cells.size(), header.size()) << line;
        rows.emplace_back(std::stoi(cells[devices_at]), std::stod(cells[speedup_at]));
    }
    ASSERT_EQ(rows.size(), 4u) << r.output;  // two scenes x (1, 2)
    for (size_t i = 0; i < rows.size(); i += 2) {
        EXPECT_EQ(rows[i].first, 1);
        EXPECT_EQ(rows[i].second, 0.0);
        EXPECT_EQ(rows[i + 1].first, 2);
        EXPECT_GT(rows[i + 1].second, 0.2);
    }
}

// Long-run throughput, shortened: every scene on both CPU drivers, with the Vulkan/OpenCL ratio
// of the two (the same kind of device) equal to the ratio of their rays/s cells.
TEST(BenchCli, ThroughputTableHasRatios) {
    const auto dir = std::filesystem::temp_directory_path() / "mcpt_bench_throughput_test";
    std::filesystem::remove_all(dir);
    std::filesystem::create_directories(dir / "no-models");
    const std::string prefix = (dir / "tp").string();
    std::string backends = " --backend opencl:" + test::test_opencl_device();
#if MCPT_WITH_VULKAN
    backends += " --backend vulkan";
#endif
    const CliRun r = run_mcpt("bench --throughput --quick --tree sah,bvh --time 0.2 --models " +
                              (dir / "no-models").string() + backends + " -o " + prefix);
    ASSERT_EQ(r.status, 0) << r.output;
    const std::string csv = read_file(prefix + ".csv");
    std::istringstream lines(csv);
    std::string line;
    std::getline(lines, line);  // header
    std::vector<std::vector<std::string>> rows;
    for (; std::getline(lines, line);) {
        const std::vector<std::string> cells = csv_cells(line);
        ASSERT_EQ(cells.size(), 20u) << line;
        EXPECT_EQ(cells[19], "0") << line;  // walk steps: the device's (CPU devices: none)
        EXPECT_EQ(cells[15], "1") << line;  // one device
        EXPECT_TRUE(cells[2] == "sah" || cells[2] == "bvh") << line;
        EXPECT_GT(std::stod(cells[9]), 0.0) << line;   // M rays/s
        EXPECT_GT(std::stod(cells[12]), 0.0) << line;  // triangle tests per ray
        EXPECT_GE(std::stod(cells[17]), 0.0) << line;  // build ms
        // Bytes per triangle: the tree's and the 36 of its corners.
        EXPECT_GT(std::stod(cells[18]), 36.0) << line;
        rows.push_back(cells);
    }
    // Per scene, each tree's rows in turn.
    for (size_t i = 0; i < rows.size(); ++i)
        EXPECT_EQ(rows[i][2], (i / (rows.size() / 4)) % 2 == 0 ? "sah" : "bvh") << i;
#if MCPT_WITH_VULKAN
    ASSERT_EQ(rows.size(), 8u) << csv;
    for (size_t i = 0; i < rows.size(); i += 2) {
        EXPECT_EQ(rows[i][3], "opencl");
        EXPECT_EQ(rows[i + 1][3], "vulkan");
        EXPECT_NEAR(std::stod(rows[i + 1][10]), std::stod(rows[i + 1][9]) / std::stod(rows[i][9]),
                    1e-3 * std::stod(rows[i + 1][10]) + 1e-3);
    }
#else
    ASSERT_EQ(rows.size(), 4u) << csv;
#endif
}

// --walk-steps: rows for each count, each from a build with that count (the compile log: a
// backend that kept its first build would pass the rows' count alone).
TEST(BenchCli, ThroughputRowsForEachWalkCount) {
    const auto dir = std::filesystem::temp_directory_path() / "mcpt_bench_walk_test";
    std::filesystem::remove_all(dir);
    std::filesystem::create_directories(dir / "no-models");
    const std::string prefix = (dir / "tp").string(), log = (dir / "compile.log").string();
    std::string backends = " --backend opencl:" + test::test_opencl_device();
#if MCPT_WITH_VULKAN
    backends += " --backend vulkan";
#endif
    const CliRun r = run_mcpt(
        "bench --throughput --quick --tree bvh --walk-steps 0,2 --time 0.1 "
        "--width 32 --height 32 --models " +
            (dir / "no-models").string() + backends + " -o " + prefix,
        "MCPT_COMPILE_LOG=" + log);
    ASSERT_EQ(r.status, 0) << r.output;
    std::istringstream lines(read_file(prefix + ".csv"));
    std::string line;
    std::getline(lines, line);
    const std::vector<std::string> header = csv_cells(line);
    ASSERT_EQ(header.back(), "walk_steps") << line;
    std::vector<std::string> walks;
    for (; std::getline(lines, line);) walks.push_back(csv_cells(line).back());
    const size_t apis = MCPT_WITH_VULKAN ? 2 : 1;
    ASSERT_EQ(walks.size(), 2 * 2 * apis);  // two scenes, two counts
    for (size_t i = 0; i < walks.size(); ++i)
        EXPECT_EQ(walks[i], i % (2 * apis) < apis ? "0" : "2");
    EXPECT_NE(r.output.find("| bvh, walk 2 |"), std::string::npos) << r.output;
    // Each API built with each count ("<api>\t<seconds>\t<settings>" a line).
    std::istringstream built(read_file(log));
    std::vector<std::string> builds;
    for (std::string l; std::getline(built, l);) {
        const std::string api = l.substr(0, l.find('\t'));
        for (const char* want : {"MCPT_WALK_STEPS=0", "MCPT_WALK_STEPS=2"})
            if ((api == "opencl" || api == "vulkan") && (l + " ").find(want) != std::string::npos)
                builds.push_back(api + " " + want);
    }
    for (const char* api : {"opencl", "vulkan"}) {
        if (std::string(api) == "vulkan" && !MCPT_WITH_VULKAN) continue;
        // OpenCL's build options leave a count of 0 out.
        if (std::string(api) == "vulkan") {
            EXPECT_NE(std::find(builds.begin(), builds.end(), "vulkan MCPT_WALK_STEPS=0"),
                      builds.end());
        }
        EXPECT_NE(std::find(builds.begin(), builds.end(), std::string(api) + " MCPT_WALK_STEPS=2"),
                  builds.end())
            << api;
    }
    const CliRun bad = run_mcpt("bench --throughput --quick --walk-steps 33");
    EXPECT_NE(bad.status, 0);
}

TEST(BenchSvg, LogLogPlotHasSeriesLegendAndEscapes) {
    SvgPlot plot;
    plot.title = "a <b> & c";
    plot.series.push_back({"first", {1, 10, 100}, {5, 2, 0.5}, "", false, true});
    plot.series.push_back({"skips <= 0", {0, 10, 1000}, {1, -1, 3}, "#123456", true, false});
    const std::string svg = render_svg(plot);
    EXPECT_NE(svg.find("a &lt;b&gt; &amp; c"), std::string::npos);
    EXPECT_NE(svg.find(">first</text>"), std::string::npos);
    EXPECT_NE(svg.find("stroke=\"#123456\""), std::string::npos);
    EXPECT_EQ(std::count(svg.begin(), svg.end(), '<') - std::count(svg.begin(), svg.end(), '>'), 0);
    EXPECT_EQ(svg.find("nan"), std::string::npos);
    EXPECT_EQ(svg.find("inf"), std::string::npos);
}

}  // namespace
}  // namespace mcpt
