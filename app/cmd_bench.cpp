// mcpt bench: the thesis' tables as a benchmark. For each model, tree (none, the thesis'
// median tree at depth 3, SAH) and backend/device: tree build time and bytes, time per frame
// at a fixed resolution and sample count, samples/s and rays/s, and the work per ray
// (triangle tests, node visits) counted by the shared traversal on the CPU in a separate,
// untimed pass. Writes prefix.md, prefix.csv and prefix.svg; prints the table.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <sstream>

#include "app/bench_common.h"
#include "app/bench_specialize.h"
#include "app/bench_throughput.h"
#include "app/commands.h"
#include "common/accel/cpu_trace.h"
#include "common/error.h"
#include "common/io/atomic_file.h"
#include "common/io/svg_plot.h"
#include "common/render/render_loop.h"
#include "common/scene/builtin_scenes.h"
#include "opencl/cl_backend.h"
#if MCPT_WITH_VULKAN
#include "vulkan/vk_backend.h"
#endif

namespace mcpt {

namespace {

struct TreeConfig {
    const char* label;
    const char* kind;
    int depth;
};
// The thesis' trees (none, the median tree of depth 3, the SAH k-d tree), then the BVH.
const TreeConfig kTrees[] = {
    {"none", "none", -1}, {"median-3", "median", 3}, {"sah", "sah", -1}, {"bvh", "bvh", -1}};

struct Row {
    std::string model, tree, backend, device;
    size_t triangles = 0;
    double build_ms = 0, ms_per_frame = 0, msamples = 0, mrays = 0;
    size_t tree_bytes = 0;
    Counts counts;
    std::string note;  // non-empty: skipped, with the reason
};

// The scenes: cornell always, then the models present (quick: the small ones only).
std::vector<std::pair<std::string, Scene>> bench_scenes(const BenchArgs& a) {
    std::vector<std::pair<std::string, Scene>> out;
    out.emplace_back("cornell", load_scene_argument("cornell"));
    const std::vector<std::string> names =
        a.quick ? std::vector<std::string>{"cube", "teapot"}
                : std::vector<std::string>{"cube",       "teapot",      "bunny",      "dragon-11k",
                                           "dragon-48k", "dragon-202k", "dragon-871k"};
    for (const std::string& n : names) {
        const std::string path = a.models + "/" + n + ".glb";
        if (std::filesystem::exists(path)) out.emplace_back(n, load_scene_argument(path));
    }
    if (out.size() == 1) {
        std::printf("note: no models in '%s' (scripts/fetch-models); using a generated mesh\n",
                    a.models.c_str());
        std::fflush(stdout);
        Scene mesh = make_bumpy_sphere_scene(24);
        validate_scene(mesh);
        out.emplace_back("generated-sphere", mesh);
    }
    return out;
}

std::string markdown_table(const std::vector<Row>& rows) {
    std::string t =
        "| model | triangles | tree | backend/device | build ms | tree bytes | ms/frame | "
        "M samples/s | Mrays/s | tri tests/ray | node visits/ray |\n"
        "|---|---:|---|---|---:|---:|---:|---:|---:|---:|---:|\n";
    for (const Row& r : rows) {
        t += "| " + r.model + " | " + std::to_string(r.triangles) + " | " + r.tree + " | " +
             r.backend + ": " + r.device + " | " + fmt("%.2f", r.build_ms) + " | " +
             std::to_string(r.tree_bytes) + " | ";
        if (!r.note.empty()) {
            t += r.note + " | | | | |\n";
            continue;
        }
        t += fmt("%.2f", r.ms_per_frame) + " | " + fmt("%.3f", r.msamples) + " | " +
             fmt("%.2f", r.mrays) + " | " + fmt("%.1f", r.counts.paths.tests_per_ray()) + " | " +
             fmt("%.1f", r.counts.paths.visits_per_ray()) + " |\n";
    }
    return t;
}

void write_csv(const std::string& path, const std::vector<Row>& rows, const RenderOptions& ro) {
    std::ostringstream f;  // written whole at the end (atomic_file.h)
    f << "model,triangles,tree,backend,device,build_ms,tree_bytes,ms_per_frame,msamples_per_s,"
         "mrays_per_s,tri_tests_per_ray,node_visits_per_ray,camera_tri_tests_per_ray,"
         "camera_node_visits_per_ray,rays_per_sample,width,height,spp,note\n";
    for (const Row& r : rows) {
        f << r.model << ',' << r.triangles << ',' << r.tree << ',' << r.backend << ",\"" << r.device
          << "\"," << r.build_ms << ',' << r.tree_bytes << ',' << r.ms_per_frame << ','
          << r.msamples << ',' << r.mrays << ',' << r.counts.paths.tests_per_ray() << ','
          << r.counts.paths.visits_per_ray() << ',' << r.counts.camera.tests_per_ray() << ','
          << r.counts.camera.visits_per_ray() << ',' << r.counts.rays_per_path << ',' << ro.width
          << ',' << ro.height << ',' << ro.spp << ",\"" << r.note << "\"\n";
    }
    write_text_atomically(path, f.str());
}

void write_plot(const std::string& path, const std::vector<Row>& rows, const RenderOptions& ro) {
    // One curve per backend x tree, points sorted by triangle count.
    SvgPlot plot;
    plot.title = "Time per frame against triangles (" + std::to_string(ro.width) + "x" +
                 std::to_string(ro.height) + ", " + std::to_string(ro.spp) + " spp)";
    plot.x_label = "triangles";
    plot.y_label = "ms per frame";
    std::vector<std::string> keys;
    for (const Row& r : rows) {
        const std::string key = r.tree + " @ " + r.backend + ": " + r.device;
        if (std::find(keys.begin(), keys.end(), key) == keys.end()) keys.push_back(key);
    }
    for (const std::string& key : keys) {
        std::vector<std::pair<double, double>> pts;
        for (const Row& r : rows)
            if (r.note.empty() && r.tree + " @ " + r.backend + ": " + r.device == key)
                pts.push_back({double(r.triangles), r.ms_per_frame});
        std::sort(pts.begin(), pts.end());
        SvgSeries s;
        s.label = key.substr(0, 60);
        s.dashed = key.rfind("none", 0) == 0;
        for (const auto& [x, y] : pts) s.x.push_back(x), s.y.push_back(y);
        plot.series.push_back(s);
    }
    write_svg(path, plot);
}

}  // namespace

void run_bench(const BenchArgs& a) {
    if (a.throughput) {
        ThroughputBenchArgs t;
        t.backends = a.backends, t.models = a.models, t.quick = a.quick;
        t.output = a.output == "bench" ? "bench-throughput" : a.output;
        t.width = a.width > 0 ? a.width : (a.quick ? 64 : 1024);
        t.height = a.height > 0 ? a.height : (a.quick ? 64 : 1024);
        t.seconds = a.seconds > 0 ? a.seconds : (a.quick ? 0.3 : 5);
        t.warmup_seconds = a.quick ? 0.1 : 1;
        t.tree = a.tree;
        t.device_counts = a.device_counts;
        t.walk_steps = a.walk_steps;
        run_throughput_bench(t);
        return;
    }
    if (a.specialize) {
        SpecializeBenchArgs s;
        s.backends = a.backends, s.models = a.models;
        s.output = a.output == "bench" ? "bench-specialize" : a.output;
        s.width = a.width > 0 ? a.width : (a.quick ? 64 : 256);
        s.height = a.height > 0 ? a.height : (a.quick ? 64 : 256);
        s.spp = a.spp > 0 ? a.spp : (a.quick ? 2 : 4);
        s.frames = a.frames;
        run_specialize_bench(s);
        return;
    }
    RenderOptions ro;
    ro.width = a.width > 0 ? a.width : (a.quick ? 64 : 256);
    ro.height = a.height > 0 ? a.height : (a.quick ? 64 : 256);
    ro.spp = a.spp > 0 ? a.spp : (a.quick ? 2 : 4);
    const double max_frame_s = a.quick ? std::min(a.max_frame_seconds, 5.0) : a.max_frame_seconds;
    std::vector<OpenBackend> backends = open_backends(a.backends);
    const auto scenes = bench_scenes(a);
    std::printf("bench: %dx%d, %llu spp, %d timed frames (median), %zu scene(s), %zu backend(s)\n",
                ro.width, ro.height, (unsigned long long)ro.spp, a.frames, scenes.size(),
                backends.size());
    std::fflush(stdout);
    std::vector<Row> rows;
    for (const auto& [name, scene] : scenes) {
        RenderOptions sro = ro;
        sro.max_depth = uint32_t(default_max_depth(scene));
        for (const TreeConfig& tc : kTrees) {
            // Tree, then the untimed counting pass (work per ray, rays per sample).
            const KdTree tree = build_kdtree(scene.triangles, tree_options(tc.kind, tc.depth));
            const GpuScene g = pack_scene(scene, tree);
            const Counts counts = count_work(g, scene, sro, tc.kind);
            const double tests_per_frame = counts.paths.tests_per_ray() * counts.rays_per_path *
                                           double(sro.width) * sro.height * double(sro.spp);
            for (OpenBackend& ob : backends) {
                Row row;
                row.model = name, row.tree = tc.label, row.triangles = scene.triangles.size();
                row.backend = ob.backend->device().backend, row.device = ob.backend->device().name;
                row.build_ms = tree.stats.build_seconds * 1e3, row.tree_bytes = tree.stats.bytes;
                row.counts = counts;
                // Skip what would take absurdly long (triangle tests per second measured with
                // tree none: PoCL on 2 cores ~3e7, an H100 ~1.3e9).
                const bool cpu = ob.backend->device().type == "cpu";
                const double est_s = tests_per_frame / (cpu ? 3e7 : 1e9);
                if (cpu && tc.kind == std::string("none") && row.triangles > 100000) {
                    row.note = "skipped: tree none with > 100k triangles on a CPU device";
                } else if (est_s > max_frame_s) {
                    row.note = "skipped: estimated " + fmt("%.0f", est_s) + " s/frame";
                } else {
                    const FrameTiming ft = time_frames(*ob.backend, g, scene.camera, sro, a.frames);
                    row.ms_per_frame = ft.ms_per_frame;
                    row.msamples = ft.msamples;
                    row.mrays = ft.mrays;
                }
                std::fprintf(stderr, "  %s %s %s: %s\n", name.c_str(), tc.label, ob.spec.c_str(),
                             row.note.empty() ? fmt("%.2f ms/frame", row.ms_per_frame).c_str()
                                              : row.note.c_str());
                rows.push_back(row);
            }
        }
    }
    const std::string table = markdown_table(rows);
    std::printf("\n%s", table.c_str());
    std::printf(
        "\ntri tests/ray and node visits/ray: all rays of full paths (camera, bounce, "
        "shadow), counted on the CPU; ms/frame: median of %d frames\n",
        a.frames);
    write_text_atomically(a.output + ".md", table);
    write_csv(a.output + ".csv", rows, ro);
    write_plot(a.output + ".svg", rows, ro);
    std::printf("wrote %s.md, %s.csv, %s.svg\n", a.output.c_str(), a.output.c_str(),
                a.output.c_str());
}

}  // namespace mcpt
