// mcpt bench --throughput: long renders (a warm-up, then seconds of tracing at 1024^2) on the
// Cornell box and the seed meshes for every backend given, with the tree --tree picks for each
// device (auto by default): samples/s and rays/s, the Vulkan/OpenCL ratio per scene and device,
// node visits and triangle tests per ray (counted on the CPU), the node and triangle bytes that
// implies per ray and the bandwidth at the measured rate, and the structure's build time and
// bytes per triangle (ours, or the driver's for rayquery and raypipeline), and the BVH walk's
// node steps each kernel was built with (--walk-steps: rows for each). Writes prefix.md,
// prefix.csv and prefix.svg.
#include "app/bench_throughput.h"

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <sstream>

#include "app/bench_common.h"
#include "app/commands.h"
#include "common/io/atomic_file.h"
#include "common/io/svg_plot.h"
#include "common/render/prepare.h"
#include "common/render/session.h"
#include "common/scene/builtin_scenes.h"
#include "common/scene/scene.h"

namespace mcpt {

namespace {

// Bytes the traversal reads per node visit and per triangle test (an 8-byte node; a leaf index
// and a 40-byte triangle): a lower bound on the memory traffic a ray causes.
constexpr double kNodeBytes = sizeof(gpu::KdNode);
constexpr double kBvhNodeBytes = sizeof(gpu::BvhNode);
constexpr double kTestBytes = sizeof(uint32_t) + sizeof(gpu::GpuTriangle);

struct ThroughputRow {
    std::string scene, tree, backend, device, type;
    size_t triangles = 0;
    int devices = 1;     // rendering the image together
    double speedup = 0;  // several devices: rays/s over the one-device row's (same API); 0: none
    double seconds = 0, msamples = 0, mrays = 0;
    double visits_per_ray = 0, tests_per_ray = 0;
    // The structure traced: built in build_ms (ours on the host, the driver's on the device),
    // bytes per triangle (ours: nodes, leaf indices and the 36 bytes of a triangle's corners;
    // the driver's: its structures, which hold the corners).
    double build_ms = 0, bytes_per_triangle = 0;
    int walk = -1;  // --walk-steps: the BVH walk's node steps (MCPT_WALK_STEPS); -1: the device's
    uint32_t walk_used = 0;  // the steps the kernel was built with (walk_steps(): 0, walked whole)
    // Vulkan rows: rays/s over the OpenCL rays/s of the same device, else of the same kind of
    // device (a CPU driver against a CPU driver); 0: none.
    double ratio = 0;
    double bytes_per_ray() const {
        return visits_per_ray * (tree == "bvh" ? kBvhNodeBytes : kNodeBytes) +
               tests_per_ray * kTestBytes;
    }
    double gbytes_per_s() const { return bytes_per_ray() * mrays * 1e-3; }
    // Work per ray counted on the CPU (not where the driver traces).
    bool counted() const { return tree != "rayquery" && tree != "raypipeline"; }
};

std::vector<std::pair<std::string, Scene>> throughput_scenes(const ThroughputBenchArgs& a) {
    std::vector<std::pair<std::string, Scene>> out;
    out.emplace_back("cornell", load_scene_argument("cornell"));
    // Metallic-roughness spheres, and the textured scene (fetch-models writes it).
    if (!a.quick) out.emplace_back("materials", load_scene_argument("materials"));
    const std::vector<std::string> names =
        a.quick ? std::vector<std::string>{}
                : std::vector<std::string>{"textured", "bunny", "dragon-48k", "dragon-871k"};
    bool meshes = false;  // a scanned mesh among them
    for (const std::string& n : names) {
        const std::string path = a.models + "/" + n + ".glb";
        if (std::filesystem::exists(path)) {
            out.emplace_back(n, load_scene_argument(path));
            meshes = meshes || n != "textured";
        } else {
            std::printf("note: %s missing (scripts/fetch-models): skipped\n", path.c_str());
        }
    }
    if (!meshes) {
        Scene mesh = make_bumpy_sphere_scene(a.quick ? 16 : 128);
        validate_scene(mesh);
        out.emplace_back("generated-sphere", mesh);
    }
    return out;
}

std::string markdown_table(const std::vector<ThroughputRow>& rows) {
    std::string t =
        "| scene | triangles | tree | backend/device | devices | M samples/s | M rays/s | "
        "speed-up | Vulkan/OpenCL | node visits/ray | tri tests/ray | bytes/ray | GB/s | build "
        "ms | bytes/triangle |\n"
        "|---|---:|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n";
    for (const ThroughputRow& r : rows) {
        t += "| " + r.scene + " | " + std::to_string(r.triangles) + " | " + r.tree +
             (r.walk >= 0 || r.walk_used > 0 ? ", walk " + std::to_string(r.walk_used)
                                             : std::string()) +
             " | " + r.backend + ": " + r.device + " | " + std::to_string(r.devices) + " | " +
             fmt("%.1f", r.msamples) + " | " + fmt("%.1f", r.mrays) + " | " +
             (r.speedup > 0 ? fmt("%.2f", r.speedup) : "") + " | " +
             (r.ratio > 0 ? fmt("%.2f", r.ratio) : "") + " | " +
             (r.counted()
                  ? fmt("%.1f", r.visits_per_ray) + " | " + fmt("%.1f", r.tests_per_ray) + " | " +
                        fmt("%.0f", r.bytes_per_ray()) + " | " + fmt("%.1f", r.gbytes_per_s())
                  : std::string("driver's | driver's | | ")) +
             " | " + fmt("%.1f", r.build_ms) + " | " + fmt("%.1f", r.bytes_per_triangle) + " |\n";
    }
    return t;
}

void write_csv(const std::string& path, const std::vector<ThroughputRow>& rows, int w, int h) {
    std::ostringstream f;
    f << "scene,triangles,tree,backend,device,width,height,seconds,msamples_per_s,mrays_per_s,"
         "vulkan_over_opencl,node_visits_per_ray,tri_tests_per_ray,bytes_per_ray,gbytes_per_s,"
         "devices,speedup,build_ms,bytes_per_triangle,walk_steps\n";
    for (const ThroughputRow& r : rows) {
        f << r.scene << "," << r.triangles << "," << r.tree << "," << r.backend << ",\"" << r.device
          << "\"," << w << "," << h << "," << fmt("%.3f", r.seconds) << ","
          << fmt("%.3f", r.msamples) << "," << fmt("%.3f", r.mrays) << "," << fmt("%.4f", r.ratio)
          << ","
          << (r.counted()
                  ? fmt("%.3f", r.visits_per_ray) + "," + fmt("%.3f", r.tests_per_ray) + "," +
                        fmt("%.1f", r.bytes_per_ray()) + "," + fmt("%.3f", r.gbytes_per_s())
                  : std::string(",,,"))
          << "," << r.devices << "," << fmt("%.3f", r.speedup) << "," << fmt("%.3f", r.build_ms)
          << "," << fmt("%.2f", r.bytes_per_triangle) << "," << r.walk_used << "\n";
    }
    write_text_atomically(path, f.str());
}

// M rays/s against triangle count, one line per backend/device.
void write_plot(const std::string& path, const std::vector<ThroughputRow>& rows) {
    SvgPlot plot;
    plot.title = "Throughput: M rays/s against triangles (long renders)";
    plot.x_label = "triangles";
    plot.y_label = "M rays/s";
    std::vector<std::string> keys;
    for (const ThroughputRow& r : rows) {
        const std::string key =
            r.backend + ": " + r.device + (r.devices > 1 ? " x" + std::to_string(r.devices) : "");
        size_t k = 0;
        while (k < keys.size() && keys[k] != key) ++k;
        if (k == keys.size()) keys.push_back(key), plot.series.push_back({});
        plot.series[k].label = key.substr(0, 60);
        plot.series[k].x.push_back(double(std::max<size_t>(1, r.triangles)));
        plot.series[k].y.push_back(r.mrays);
    }
    write_svg(path, plot);
}

}  // namespace

void run_throughput_bench(const ThroughputBenchArgs& a) {
    // One session per device, driven as `mcpt render` drives its own (render_until()); or,
    // with device counts, per API and count one session on its first N devices.
    std::vector<std::unique_ptr<Session>> sessions;
    std::vector<int> counts;  // devices per session
    std::vector<OpenBackend> opened = open_backends(a.backends);
    if (a.device_counts.empty()) {
        for (OpenBackend& ob : opened) {
            sessions.push_back(std::make_unique<Session>(std::move(ob.backend)));
            counts.push_back(1);
        }
    } else {
        std::vector<std::pair<std::string, std::vector<std::string>>> apis;
        for (const OpenBackend& ob : opened) {
            // Per API and kind of device: the first N GPUs, never a CPU driver among them.
            const std::string api = ob.backend->device().backend;
            const std::string group = api + " " + ob.backend->device().type;
            const std::string spec = api + ":" + std::to_string(ob.backend->device().index);
            auto it = std::find_if(apis.begin(), apis.end(),
                                   [&](const auto& p) { return p.first == group; });
            if (it == apis.end()) apis.push_back({group, {}}), it = std::prev(apis.end());
            it->second.push_back(spec);
        }
        opened.clear();  // each session opens its devices again
        for (const auto& [api, specs] : apis)
            for (int n : a.device_counts) {
                if (n > int(specs.size())) {
                    std::printf("note: %s has %zu devices here: no row for %d\n", api.c_str(),
                                specs.size(), n);
                    continue;
                }
                const std::vector<std::string> first(specs.begin(), specs.begin() + n);
                sessions.push_back(std::make_unique<Session>(first, BackendOptions{}));
                counts.push_back(n);
            }
    }
    const auto scenes = throughput_scenes(a);
    std::printf("bench --throughput: %dx%d, tree %s, %.1f s warm-up, %.1f s timed per row\n",
                a.width, a.height, a.tree.c_str(), a.warmup_seconds, a.seconds);
    std::fflush(stdout);
    std::vector<ThroughputRow> rows;
    std::vector<std::string> trees;
    std::stringstream tree_list(a.tree);
    for (std::string t; std::getline(tree_list, t, ',');) trees.push_back(t);
    // --walk-steps: rows for each count ($MCPT_WALK_STEPS, restored after), else the device's.
    const std::vector<int> walks = a.walk_steps.empty() ? std::vector<int>{-1} : a.walk_steps;
    const char* walk_env = std::getenv("MCPT_WALK_STEPS");
    const std::string walk_before = walk_env ? walk_env : "";
    const size_t per_tree = walks.size() * sessions.size();
    for (const auto& [name, scene] : scenes) {
        const size_t first = rows.size();
        for (size_t run = 0; run < trees.size() * per_tree; ++run) {
            const size_t k = run % sessions.size();
            const int walk = walks[run % per_tree / sessions.size()];
            if (walk >= 0) setenv("MCPT_WALK_STEPS", std::to_string(walk).c_str(), 1);
            Session& s = *sessions[k];
            Backend& backend = s.backend();
            // The driver's tracing only where the device has it (OpenCL never).
            const TreeKind kind = parse_tree_kind(trees[run / per_tree]);
            const DeviceInfo& d = backend.device();
            if ((kind == TreeKind::RayQuery && !d.ray_queries) ||
                (kind == TreeKind::RayPipeline && !d.ray_pipelines)) {
                if (&scene == &scenes.front().second)
                    std::printf("note: %s: no %s here: no rows\n", d.label().c_str(),
                                tree_kind_name(kind));
                continue;
            }
            s.set_scene(scene);
            s.settings().width = a.width, s.settings().height = a.height;
            s.settings().tree = trees[run / per_tree];
            // Warm-up (compilation done, clocks up, dispatch sizes settled), then the timed run
            // from zero.
            s.settings().seed = 1;
            RenderGoal goal;
            goal.seconds = a.warmup_seconds;
            render_until(s, goal);
            s.reset();
            goal.seconds = a.seconds;
            render_until(s, goal);
            const RenderResult& r = s.result();
            const GpuScene& g = s.prepared();
            RenderOptions ro;
            ro.width = a.width, ro.height = a.height;
            ro.max_depth = uint32_t(s.max_depth());
            ThroughputRow row;
            row.scene = name;
            row.tree = tree_kind_name(g.tree_kind);
            row.walk = walk;
            row.walk_used =
                walk_steps(d, g.features, traced_by_driver(g.tree_kind), g.stack_size - 1);
            row.backend = backend.device().backend, row.device = backend.device().name;
            row.type = backend.device().type;
            row.devices = counts[k];
            row.triangles = g.triangles.size();
            row.seconds = r.seconds;
            row.msamples = double(r.spp) * a.width * a.height / r.seconds * 1e-6;
            row.mrays = r.rays / r.seconds * 1e-6;
            if (traced_by_driver(g.tree_kind)) {
                const Backend::DeviceBuild b = backend.device_build();
                row.build_ms = b.seconds * 1e3;
                row.bytes_per_triangle =
                    double(b.bytes) / double(std::max<size_t>(1, row.triangles));
            } else {
                row.build_ms = g.tree_stats.build_seconds * 1e3;
                row.bytes_per_triangle = double(g.tree_stats.bytes + 36 * row.triangles) /
                                         double(std::max<size_t>(1, row.triangles));
            }
            // The driver's traversal, whose work the CPU cannot count.
            if (row.counted()) {
                const Counts c = count_work(g, scene, ro, row.tree);
                row.visits_per_ray = c.paths.visits_per_ray();
                row.tests_per_ray = c.paths.tests_per_ray();
            }
            const std::string tree_walk = row.tree + (walk >= 0 || row.walk_used > 0
                                                          ? " walk " + std::to_string(row.walk_used)
                                                          : std::string());
            std::printf("  %-16s %-12s %-40.40s x%d %9.1f M samples/s %9.1f M rays/s\n",
                        name.c_str(), tree_walk.c_str(), (row.backend + ": " + row.device).c_str(),
                        row.devices, row.msamples, row.mrays);
            std::fflush(stdout);
            rows.push_back(row);
        }
        // Several devices against one of the same API, per scene.
        for (size_t i = first; i < rows.size(); ++i)
            for (size_t j = first; j < rows.size(); ++j)
                if (rows[i].devices > 1 && rows[j].devices == 1 &&
                    rows[j].backend == rows[i].backend && rows[j].tree == rows[i].tree &&
                    rows[j].walk == rows[i].walk && rows[j].mrays > 0)
                    rows[i].speedup = rows[i].mrays / rows[j].mrays;
        // Vulkan against OpenCL per scene: the same device, else the same kind of device (and
        // as many devices).
        for (size_t i = first; i < rows.size(); ++i) {
            if (rows[i].backend != "vulkan") continue;
            for (int same_name = 1; same_name >= 0 && rows[i].ratio == 0; --same_name) {
                for (size_t j = first; j < rows.size() && rows[i].ratio == 0; ++j) {
                    const bool match = rows[j].devices == rows[i].devices &&
                                       rows[j].tree == rows[i].tree &&
                                       rows[j].walk == rows[i].walk &&
                                       (same_name ? rows[j].device == rows[i].device
                                                  : rows[j].type == rows[i].type);
                    if (rows[j].backend == "opencl" && match && rows[j].mrays > 0)
                        rows[i].ratio = rows[i].mrays / rows[j].mrays;
                }
            }
        }
    }
    if (walk_env)
        setenv("MCPT_WALK_STEPS", walk_before.c_str(), 1);
    else
        unsetenv("MCPT_WALK_STEPS");
    const std::string table = markdown_table(rows);
    std::printf("\n%s", table.c_str());
    std::printf(
        "\nnode visits and triangle tests per ray: full paths, counted on the CPU (rayquery, "
        "raypipeline: the driver's, not counted); bytes/ray: "
        "%.0f per k-d node visit, %.0f per BVH node visit, %.0f per triangle test (leaf index "
        "and triangle); GB/s: bytes/ray x rays/s, a lower bound on the traffic; Vulkan/OpenCL: "
        "rays/s against OpenCL on the same device, else on the same kind of device; build ms: "
        "ours on the host, the driver's on the device; bytes/triangle: ours the tree and 36 "
        "bytes of corners, the driver's its structures\n",
        kNodeBytes, kBvhNodeBytes, kTestBytes);
    write_text_atomically(a.output + ".md", table);
    write_csv(a.output + ".csv", rows, a.width, a.height);
    write_plot(a.output + ".svg", rows);
    std::printf("wrote %s.md, %s.csv, %s.svg\n", a.output.c_str(), a.output.c_str(),
                a.output.c_str());
}

}  // namespace mcpt
