// mcpt bench --specialize: what leaving out unused code buys. Per scene (a diffuse-only
// mesh, the Cornell box with glass and mirror spheres, spheres only) and backend/device:
// time per frame of the full kernel, of the build for the scene's features (same SAH
// tree), and of that build with --tree auto; and the compile / pipeline-creation time of
// the full and the specialized build, cold (a compile nonce defeats every cache) and
// cached (a new backend building what was just built).
#include "app/bench_specialize.h"

#include <cstdio>
#include <fstream>
#include <random>
#include <sstream>

#include "app/bench_common.h"
#include "app/commands.h"
#include "common/error.h"
#include "common/io/atomic_file.h"
#include "common/render/scene_features.h"
#include "common/scene/builtin_scenes.h"

namespace mcpt {

namespace {

struct Compile {
    double cold_s = 0, cached_s = 0;
};

struct SpecRow {
    std::string scene, backend, device, left_out, auto_tree;
    FrameTiming full, special, special_auto;
    Compile full_compile, special_compile;
};

// The scenes: a diffuse-only mesh (the bunny in its box, else a generated one), the
// Cornell box, spheres only.
std::vector<std::pair<std::string, Scene>> specialize_scenes(const std::string& models) {
    std::vector<std::pair<std::string, Scene>> out;
    const std::string bunny = models + "/bunny.glb";
    std::FILE* f = std::fopen(bunny.c_str(), "rb");
    if (f) {
        std::fclose(f);
        out.emplace_back("bunny (diffuse mesh)", load_scene_argument(bunny));
    } else {
        Scene s = make_builtin_scene("cornell");
        s.spheres.clear();
        s.name = "walls only (diffuse mesh)";
        validate_scene(s);
        out.emplace_back(s.name, s);
    }
    out.emplace_back("cornell", load_scene_argument("cornell"));
    out.emplace_back("spheres", load_scene_argument("spheres"));
    return out;
}

// Compile time of `features` on the device of `spec`, cold then cached.
Compile time_compile(const std::string& spec, const GpuScene& g, uint32_t features, int w, int h,
                     uint32_t nonce) {
    Compile c;
    BackendOptions o;
    o.features = features;
    o.compile_nonce = nonce;
    {
        auto cold = open_device(spec, o);
        cold->load(g, w, h, false);
        c.cold_s = cold->compile_seconds();
    }
    o.compile_nonce = 0;
    auto warm = open_device(spec, o);
    warm->load(g, w, h, false);  // fills the caches if this build was never made before
    auto cached = open_device(spec, o);
    cached->load(g, w, h, false);
    c.cached_s = cached->compile_seconds();
    return c;
}

std::string speedup(const FrameTiming& base, const FrameTiming& x) {
    return x.ms_per_frame > 0 ? fmt("%.2fx", base.ms_per_frame / x.ms_per_frame) : "-";
}

std::string table(const std::vector<SpecRow>& rows) {
    std::string t =
        "| scene | backend/device | left out | full ms/frame | specialized ms/frame | speed-up | "
        "+ tree auto ms/frame | speed-up | compile full cold / cached s | compile specialized "
        "cold / cached s |\n|---|---|---|---:|---:|---:|---:|---:|---:|---:|\n";
    for (const SpecRow& r : rows) {
        t += "| " + r.scene + " | " + r.backend + ": " + r.device + " | " + r.left_out + " | " +
             fmt("%.2f", r.full.ms_per_frame) + " | " + fmt("%.2f", r.special.ms_per_frame) +
             " | " + speedup(r.full, r.special) + " | " + fmt("%.2f", r.special_auto.ms_per_frame) +
             " (" + r.auto_tree + ") | " + speedup(r.full, r.special_auto) + " | " +
             fmt("%.3f", r.full_compile.cold_s) + " / " + fmt("%.3f", r.full_compile.cached_s) +
             " | " + fmt("%.3f", r.special_compile.cold_s) + " / " +
             fmt("%.3f", r.special_compile.cached_s) + " |\n";
    }
    return t;
}

void write_csv(const std::string& path, const std::vector<SpecRow>& rows) {
    std::ostringstream f;  // written whole at the end (atomic_file.h)
    f << "scene,backend,device,left_out,full_ms,specialized_ms,specialized_auto_ms,auto_tree,"
         "full_compile_cold_s,full_compile_cached_s,specialized_compile_cold_s,"
         "specialized_compile_cached_s\n";
    for (const SpecRow& r : rows) {
        f << '"' << r.scene << "\"," << r.backend << ",\"" << r.device << "\",\"" << r.left_out
          << "\"," << r.full.ms_per_frame << ',' << r.special.ms_per_frame << ','
          << r.special_auto.ms_per_frame << ',' << r.auto_tree << ',' << r.full_compile.cold_s
          << ',' << r.full_compile.cached_s << ',' << r.special_compile.cold_s << ','
          << r.special_compile.cached_s << '\n';
    }
    write_text_atomically(path, f.str());
}

}  // namespace

void run_specialize_bench(const SpecializeBenchArgs& a) {
    RenderOptions ro;
    ro.width = a.width, ro.height = a.height, ro.spp = a.spp;
    std::vector<OpenBackend> backends = open_backends(a.backends);
    const auto scenes = specialize_scenes(a.models);
    std::printf("bench --specialize: %dx%d, %llu spp, %d timed frames (median)\n", ro.width,
                ro.height, (unsigned long long)ro.spp, a.frames);
    std::fflush(stdout);
    std::mt19937 nonce_rng(std::random_device{}());
    std::vector<SpecRow> rows;
    for (const auto& [name, scene] : scenes) {
        RenderOptions sro = ro;
        sro.max_depth = uint32_t(default_max_depth(scene));
        const GpuScene g = pack_scene(scene, build_kdtree(scene.triangles, TreeOptions{}));
        for (OpenBackend& ob : backends) {
            SpecRow row;
            row.scene = name;
            row.backend = ob.backend->device().backend, row.device = ob.backend->device().name;
            row.left_out = features_left_out(g.features);
            // The same SAH tree, full kernel and specialized build.
            BackendOptions full;
            full.features = FEATURE_ALL;
            row.full = time_frames(*open_device(ob.spec, full), g, scene.camera, sro, a.frames);
            row.special = time_frames(*ob.backend, g, scene.camera, sro, a.frames);
            // The specialized build with the tree --tree auto picks for this device.
            const GpuScene ga = prepare_scene(scene, ob.backend->device(), tree_options("auto"),
                                              sro.width, sro.height);
            row.auto_tree = tree_kind_name(ga.tree_kind);
            row.special_auto = time_frames(*ob.backend, ga, scene.camera, sro, a.frames);
            // Compile times, cold and cached (non-zero nonces in the bits above the features).
            constexpr uint32_t kNonces = (1u << (32 - FEATURE_COUNT)) - 1u;
            row.full_compile = time_compile(ob.spec, g, FEATURE_ALL, sro.width, sro.height,
                                            1 + nonce_rng() % kNonces);
            row.special_compile = time_compile(ob.spec, g, g.features, sro.width, sro.height,
                                               1 + nonce_rng() % kNonces);
            std::fprintf(stderr,
                         "  %s %s: full %.2f ms, specialized %.2f ms, + auto tree %.2f ms\n",
                         name.c_str(), ob.spec.c_str(), row.full.ms_per_frame,
                         row.special.ms_per_frame, row.special_auto.ms_per_frame);
            rows.push_back(row);
        }
    }
    const std::string t = table(rows);
    std::printf("\n%s", t.c_str());
    std::printf(
        "\nspeed-up: full kernel time / specialized time (same SAH tree; '+ tree auto': with "
        "the tree --tree auto picks for the device). cold: a compile nonce defeats the driver's "
        "and mcpt's pipeline caches; cached: a new backend building the same variant again.\n");
    write_text_atomically(a.output + ".md", t);
    write_csv(a.output + ".csv", rows);
    std::printf("wrote %s.md, %s.csv\n", a.output.c_str(), a.output.c_str());
}

}  // namespace mcpt
