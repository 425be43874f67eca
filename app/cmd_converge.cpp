// mcpt converge: error against run time. Renders progressively on each backend as independent
// batches, measures RMSE, relative MSE and mean signed error against a reference at
// geometrically spaced checkpoints, fits the log-log convergence rate, flags bias, and reports
// the time each backend needs to reach a relative RMSE. Writes prefix.csv and prefix.svg, and
// with --report DIR a self-contained HTML report.
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <sstream>

#include "app/commands.h"
#include "app/mpi_job.h"
#include "common/analysis/convergence.h"
#include "common/error.h"
#include "common/io/atomic_file.h"
#include "common/io/false_color.h"
#include "common/io/html_report.h"
#include "common/io/svg_plot.h"
#include "common/render/scene_features.h"
#include "opencl/cl_backend.h"

namespace mcpt {

namespace {

struct ConvergeArgs {
    std::string scene = "cornell";
    LightingArgs lighting;
    std::vector<std::string> backends{"opencl"};
    int width = 256, height = 256;
    double seconds = 10;
    uint64_t max_spp = 0;
    std::string checkpoints = "geometric";
    std::string reference = "auto";
    uint64_t reference_spp = 1024;
    std::vector<double> targets{0.10, 0.05};
    int max_depth = -1;
    std::string tree = "auto";
    std::string output = "converge";
    std::string report;  // folder of the HTML report (index.html)
    uint32_t seed = 1;
    std::vector<std::string> samplers{"sobol"};
    std::vector<std::string> sampling{"uniform"};
    std::vector<std::string> devices;  // --device repeated: each backend's run on all of them
    bool beside_one = false;           // and on its first device alone
};

struct Run {
    std::string backend, device;
    std::vector<Checkpoint> checkpoints;
    ConvergenceReport report;
    std::vector<float> image;  // the final accumulation's mean (3 floats per pixel)
};

std::string scene_label(const Scene& scene, const std::string& arg) {
    if (!scene.name.empty()) return scene.name;
    return std::filesystem::path(arg).stem().string();
}

// The exact solution, or a high-sample render cached per scene content, size and bounces.
Reference make_reference(const ConvergeArgs& a, const Scene& scene, const GpuScene& g,
                         const RenderOptions& ro) {
    double exact = 0;
    const bool has_exact = exact_furnace_radiance(scene, exact);
    if (a.reference == "exact" && !has_exact)
        throw Error("no exact solution is known for '" + a.scene + "' (use --reference cached)");
    if (a.reference != "cached" && has_exact) {
        char src[96];
        std::snprintf(src, sizeof src, "exact: Le/(1-rho) = %g everywhere", exact);
        return constant_reference(a.width, a.height, exact, src);
    }
    // Cached: the key covers the rendered content and the kernel source, never the tree.
    const uint64_t key = reference_key(g, scene.camera, a.width, a.height, ro.max_depth,
                                       ro.rr_depth, opencl_kernel_source());
    char name[160];
    std::snprintf(name, sizeof name, "%s-%dx%d-d%u-%016llx.ref",
                  scene_label(scene, a.scene).c_str(), a.width, a.height, ro.max_depth,
                  (unsigned long long)key);
    const std::string path = reference_cache_dir() + "/" + name;
    Reference ref;
    if (load_reference(path, a.width, a.height, ref)) return ref;
    // Not cached yet: render it once on the first backend, with seeds no checkpoint uses.
    std::printf("rendering the reference (%llu spp on %s) into %s ...\n",
                (unsigned long long)a.reference_spp, a.backends[0].c_str(), path.c_str());
    std::fflush(stdout);
    std::unique_ptr<Backend> backend = open_device(a.backends[0]);
    RenderOptions r = ro;
    r.spp = a.reference_spp;
    r.seed = 0x7e000000u;
    // Independent samples: their sample variance is the reference's own error, which every
    // MSE subtracts (a low-discrepancy sampler's would overstate it).
    GpuScene independent = g;
    independent.features |= FEATURE_INDEPENDENT_SAMPLER;
    const bool bar = isatty(2);
    const RenderResult rr =
        render(*backend, independent, scene.camera, r,
               bar ? ProgressFn([](double f, const RenderResult& s) {
                   std::fprintf(stderr, "\r  reference %3d%%  %.0f s ", int(100 * f), s.seconds);
               })
                   : ProgressFn());
    if (bar) std::fprintf(stderr, "\n");
    ref = reference_from_render(rr, "rendered " + path + " (" + std::to_string(rr.spp) + " spp)");
    save_reference(path, ref);
    return ref;
}

void print_checkpoint(const Run& run, const Checkpoint& c) {
    std::printf("%-18s %-28.28s %9.3f %8llu %11.4g %8.2f%% %11.4g %+12.4g\n", run.backend.c_str(),
                run.device.c_str(), c.seconds, (unsigned long long)c.spp, c.error.rmse,
                100 * c.error.rel_rmse, c.error.rel_mse, c.error.mean_signed_error);
    std::fflush(stdout);
}

void write_csv(const std::string& path, const std::vector<Run>& runs) {
    std::ostringstream f;  // written whole at the end (atomic_file.h)
    f << "backend,device,checkpoint,seconds,spp,rmse,rel_mse,mean_signed_error,reference_noise,"
         "rel_rmse\n";
    for (const Run& r : runs) {
        for (size_t k = 0; k < r.checkpoints.size(); ++k) {
            const Checkpoint& c = r.checkpoints[k];
            char line[512];
            std::snprintf(line, sizeof line, "%s,\"%s\",%zu,%.6f,%llu,%.8g,%.8g,%.8g,%.8g,%.8g\n",
                          r.backend.c_str(), r.device.c_str(), k, c.seconds,
                          (unsigned long long)c.spp, c.error.rmse, c.error.rel_mse,
                          c.error.mean_signed_error, c.error.reference_noise, c.error.rel_rmse);
            f << line;
        }
    }
    write_text_atomically(path, f.str());
}

// The log-log plot of converge.svg and the report.
SvgPlot make_plot(const std::string& scene, const std::vector<Run>& runs) {
    SvgPlot plot;
    plot.title = "RMSE against render time: " + scene;
    plot.x_label = "seconds";
    plot.y_label = "RMSE";
    double t_min = HUGE_VAL, t_max = 0;
    for (const Run& r : runs) {
        // One curve per backend, its fitted slope in the legend.
        SvgSeries s;
        char label[160];
        std::snprintf(label, sizeof label, "%s: %.40s (slope %.3f)", r.backend.c_str(),
                      r.device.c_str(), r.report.time_fit.slope);
        s.label = label;
        for (const Checkpoint& c : r.checkpoints) {
            s.x.push_back(c.seconds), s.y.push_back(c.error.rmse);
            if (c.seconds > 0)
                t_min = std::min(t_min, c.seconds), t_max = std::max(t_max, c.seconds);
        }
        plot.series.push_back(s);
    }
    if (!runs.empty() && !runs[0].checkpoints.empty() && t_max > t_min) {
        // The ideal -1/2 line through the first backend's last checkpoint; the reference noise.
        const Checkpoint& last = runs[0].checkpoints.back();
        SvgSeries ideal;
        ideal.label = "ideal slope -1/2";
        ideal.color = "#888888", ideal.dashed = true, ideal.markers = false;
        for (double t : {t_min, t_max})
            ideal.x.push_back(t), ideal.y.push_back(last.error.rmse * std::sqrt(last.seconds / t));
        plot.series.push_back(ideal);
        if (last.error.reference_noise > 0) {
            SvgSeries floor;
            floor.label = "reference noise (subtracted)";
            floor.color = "#bbbbbb", floor.dashed = true, floor.markers = false;
            floor.x = {t_min, t_max};
            floor.y = {last.error.reference_noise, last.error.reference_noise};
            plot.series.push_back(floor);
        }
    }
    return plot;
}

// The cells of the checkpoint table, as print_checkpoint() prints them.
std::vector<std::string> checkpoint_cells(const Checkpoint& c) {
    char b[4][48];
    std::snprintf(b[0], sizeof b[0], "%.3f", c.seconds);
    std::snprintf(b[1], sizeof b[1], "%.4g", c.error.rmse);
    std::snprintf(b[2], sizeof b[2], "%.2f%%", 100 * c.error.rel_rmse);
    std::snprintf(b[3], sizeof b[3], "%.4g", c.error.rel_mse);
    char signed_error[48];
    std::snprintf(signed_error, sizeof signed_error, "%+.4g", c.error.mean_signed_error);
    return {b[0], std::to_string(c.spp), b[1], b[2], b[3], signed_error};
}

// Per pixel: mean over channels of |image - reference| / (mean reference + 0.01).
std::vector<float> relative_error_map(const std::vector<float>& image, const Reference& ref) {
    std::vector<float> map(image.size() / 3);
    for (size_t i = 0; i < map.size(); ++i) {
        double diff = 0, value = 0;
        for (int c = 0; c < 3; ++c)
            diff += std::abs(image[3 * i + c] - ref.mean[3 * i + c]), value += ref.mean[3 * i + c];
        map[i] = float(diff / (value + 0.03));
    }
    return map;
}

// The report: plot, checkpoints, fits and bias, time to error, final images and error maps.
void write_converge_report(const ConvergeArgs& a, const std::string& label, const Reference& ref,
                           const std::vector<Run>& runs, const std::string& settings,
                           const std::vector<std::string>& tte_header,
                           const std::vector<std::vector<std::string>>& tte_rows) {
    bool biased = false;
    for (const Run& r : runs) biased |= r.report.biased;
    HtmlReport h("mcpt converge " + label + ": " + (biased ? "BIASED" : "CONSISTENT"));
    h.verdict(biased ? "BIASED" : "CONSISTENT", !biased,
              biased ? "a run flattens above the noise floor"
                     : "every run converges at its expected rate",
              "overall");
    h.paragraph(settings);
    h.paragraph("Reference: " + ref.source);
    h.plot(make_plot(label, runs));

    // Fits and bias, one line per run.
    h.heading("Fits and bias");
    for (const Run& r : runs) {
        char fit[160];
        std::snprintf(fit, sizeof fit, "RMSE ~ time^%.3f, ~ spp^%.3f; ", r.report.time_fit.slope,
                      r.report.spp_fit.slope);
        h.verdict(r.backend + " " + r.device, !r.report.biased, fit + r.report.verdict());
    }
    // Time to a relative RMSE.
    h.heading("Time to a relative RMSE");
    h.table(tte_header, tte_rows);
    if (runs.size() > 1) h.paragraph("xN: time relative to " + runs[0].backend);

    // Per run: its checkpoints, final image and error map.
    constexpr float lo = 1e-4f, hi = 1.f;
    const float exposure = display_exposure(ref.mean_value());
    char shown[64];
    std::snprintf(shown, sizeof shown, " spp (sRGB, exposure %.3g)", exposure);
    for (const Run& r : runs) {
        h.heading(r.backend + ": " + r.device);
        std::vector<std::vector<std::string>> rows;
        for (const Checkpoint& c : r.checkpoints) rows.push_back(checkpoint_cells(c));
        h.table({"seconds", "spp", "rmse", "rel rmse", "rel mse", "mean signed"}, rows);
        const uint64_t spp = r.checkpoints.empty() ? 0 : r.checkpoints.back().spp;
        h.images(
            {{a.width, a.height, radiance_to_srgb8(r.image, exposure),
              "Final image, " + std::to_string(spp) + shown},
             {a.width, a.height,
              false_color_pixels(relative_error_map(r.image, ref),
                                 [&](float x) { return sequential_color(log_unit(x, lo, hi)); }),
              "Per-pixel relative error mean |image - reference| / (mean reference + 0.01), "
              "log scale: black <= 1e-4, white >= 1"}});
    }
    h.write(a.report);
    std::printf("wrote %s/index.html\n", a.report.c_str());
}

// One backend's run: its devices, and whether the other ranks of an MPI job render it too.
struct ConvergeJob {
    std::vector<std::string> specs;
    bool with_ranks = true;
    // --beside-one's run on the first device alone, before its twin on all of them. It takes
    // its twin's seeds: the same samples, so the two curves differ in time only, not in one
    // seed's luck.
    bool beside = false;
    size_t first_run = 0;  // the index of its first run among all runs, for run_seed()
};

// Each backend's runs: on its --device list (one image on several devices, coordinator.h), and
// with --beside-one on the first of them alone too (what the others add). Under mpirun each
// rank takes one device (rank_device(), or the one --device), and --beside-one's run is rank
// 0's alone. Every rank computes the same list from the same arguments.
std::vector<ConvergeJob> converge_jobs(const ConvergeArgs& a, const MpiJob& mpi) {
    std::vector<ConvergeJob> jobs;
    for (const std::string& backend : a.backends) {
        if (mpi.size > 1) {
            const std::string spec = a.devices.empty() ? rank_device(backend, mpi)
                                                       : device_specs(backend, a.devices)[0];
            if (a.beside_one) jobs.push_back({{spec}, false, true});
            jobs.push_back({{spec}, true});
            continue;
        }
        const std::vector<std::string> specs = device_specs(backend, a.devices);
        if (a.beside_one && specs.size() > 1) jobs.push_back({{specs.front()}, false, true});
        jobs.push_back({specs, false});
    }
    // Seeds: every job's runs count, but a job beside its twin's.
    size_t runs = 0;
    for (ConvergeJob& job : jobs) {
        job.first_run = runs;
        if (!job.beside) runs += a.samplers.size() * a.sampling.size();
    }
    return jobs;
}

// A session for one job: the scene and the settings every run of it shares.
std::unique_ptr<Session> open_job_session(const ConvergeArgs& a, const ConvergeJob& job,
                                          const Scene& scene, uint32_t max_depth) {
    auto session = std::make_unique<Session>(job.specs, BackendOptions{});
    session->set_scene(scene);
    session->settings().width = a.width, session->settings().height = a.height;
    session->settings().max_depth = int(max_depth);
    session->settings().tree = a.tree;  // auto: the tree this device's cost model picks
    return session;
}

// The seed of run `index` (the runs of every job counted in order, --beside-one's as its twin's).
uint32_t run_seed(const ConvergeArgs& a, size_t index) {
    return a.seed + 100000u * uint32_t(index);
}

// Ranks above 0 of an MPI job: each run that has ranks, rendered as rank 0 hands it out.
void serve_converge(const ConvergeArgs& a, const std::vector<ConvergeJob>& jobs,
                    const Scene& scene, uint32_t max_depth) {
    for (const ConvergeJob& job : jobs) {
        if (!job.with_ranks) continue;
        size_t index = job.first_run;
        std::unique_ptr<Session> session = open_job_session(a, job, scene, max_depth);
        for (const std::string& sampler : a.samplers)
            for (const std::string& sampling : a.sampling) {
                session->settings().sampler = sampler;
                session->settings().adaptive = sampling == "adaptive";
                session->settings().seed = run_seed(a, index++);
                mpi_serve(*session, false);
            }
    }
}

void run_converge(const ConvergeArgs& a) {
    const MpiJob& mpi = mpi_job();
    if (mpi.size > 1 && a.devices.size() > 1)
        throw Error("under mpirun each rank takes one device: give at most one --device");
    if (mpi.size > 1)
        for (const std::string& sampling : a.sampling)
            if (sampling == "adaptive")
                throw Error(
                    "adaptive sampling runs on one device (its plan needs the whole image's "
                    "noise): not under mpirun");
    if (mpi.rank == 0 && !a.report.empty()) prepare_report_dir(a.report);  // before rendering
    // Scene, tree, render settings.
    Scene scene = load_scene_argument(a.scene);
    scene.environment = lighting_environment(a.lighting);
    apply_light_sampling(scene, a.lighting);
    check_lit(scene);
    RenderOptions ro;
    ro.width = a.width, ro.height = a.height;
    ro.max_depth = uint32_t(a.max_depth >= 0 ? a.max_depth : default_max_depth(scene));
    const std::vector<ConvergeJob> jobs = converge_jobs(a, mpi);
    if (mpi.rank > 0) {
        serve_converge(a, jobs, scene, ro.max_depth);
        return;
    }
    const TreeOptions tree_opts = tree_options(a.tree);
    const GpuScene g = pack_scene(scene, build_kdtree(scene.triangles, tree_opts));
    const std::string label = scene_label(scene, a.scene);

    // Reference.
    const Reference ref = make_reference(a, scene, g, ro);
    char settings[256];
    std::snprintf(settings, sizeof settings,
                  "scene %s, %dx%d, max depth %u, %s checkpoints, budget %g s%s per backend",
                  label.c_str(), a.width, a.height, ro.max_depth, a.checkpoints.c_str(), a.seconds,
                  a.max_spp ? (" or " + std::to_string(a.max_spp) + " spp").c_str() : "");
    std::printf("%s\n", settings);
    std::printf("reference: %s; mean radiance %.4g\n", ref.source.c_str(), ref.mean_value());
    if (!ref.exact()) {
        std::printf(
            "reference noise: RMS standard error %.4g (%.2f%% of the mean); its variance "
            "is subtracted from every MSE below\n",
            std::sqrt(ref.noise_variance()),
            100 * std::sqrt(ref.noise_variance()) / ref.mean_value());
    }

    // Progressive renders, one backend after the other.
    std::vector<Run> runs;
    std::printf("\n%-18s %-28s %9s %8s %11s %9s %11s %12s\n", "backend", "device", "seconds", "spp",
                "rmse", "rel rmse", "rel mse", "mean signed");
    RankJob rank_job;
    rank_job.width = a.width, rank_job.height = a.height;
    for (const ConvergeJob& job : jobs) {
        std::unique_ptr<Session> owned = open_job_session(a, job, scene, ro.max_depth);
        Session& session = *owned;
        const Backend& backend = session.backend();
        size_t index = job.first_run;
        for (const std::string& sampler : a.samplers)
            for (const std::string& sampling : a.sampling) {
                session.settings().sampler = sampler;
                session.settings().adaptive = sampling == "adaptive";
                session.settings().seed = run_seed(a, index++);
                // Under mpirun: the other ranks join this run (each said it has the same job).
                if (job.with_ranks)
                    for (auto& w : mpi_remote_workers(session.fingerprint(), rank_job))
                        session.add_worker(std::move(w));
                const size_t devices = job.with_ranks ? size_t(mpi.size) : job.specs.size();
                Run run;
                run.backend = backend.device().backend;
                if (devices > 1)
                    run.backend += " x" + std::to_string(devices) + (job.with_ranks ? " ranks" : "");
                if (a.samplers.size() > 1) run.backend += "/" + sampler;
                if (a.sampling.size() > 1) run.backend += "/" + sampling;
                run.device = backend.device().name;
                if (job.specs.size() > 1)
                    for (size_t d = 1; d < session.device_names().size(); ++d)
                        run.device += " + " + session.device_names()[d];
                ProgressiveOptions po;
                po.schedule =
                    a.checkpoints == "time" ? Schedule::TimeDoubling : Schedule::SppDoubling;
                po.seconds = a.seconds, po.max_spp = a.max_spp;
                po.seed_base = session.settings().seed;
                RenderResult total;
                run.checkpoints =
                    render_progressive(session, po, ref, &total,
                                       [&](const Checkpoint& c) { print_checkpoint(run, c); });
                // What the checkpoints cost in render time: read-backs (one device) or rounds
                // whose sums are collected (several).
                if (devices > 1) {
                    std::printf("  %llu rounds, %.3f s collecting their sums\n",
                                (unsigned long long)session.rounds(), session.collect_seconds());
                    print_device_shares(session);
                } else
                    std::printf("  %llu read-backs, %.3f s\n",
                                (unsigned long long)session.readbacks(),
                                session.readback_seconds());
                // The ranks' part of this run ends (each goes on to the next).
                session.remove_workers();
                run.report =
                    analyze_convergence(run.checkpoints, ref.mean_value(), effective_pixels(total));
                if (!a.report.empty()) run.image = total.mean_image();
                runs.push_back(std::move(run));
            }
    }

    // Fits and bias.
    std::printf("\n");
    for (const Run& r : runs) {
        std::printf("%s %s: RMSE ~ time^%.3f, ~ spp^%.3f; %s\n", r.backend.c_str(),
                    r.device.c_str(), r.report.time_fit.slope, r.report.spp_fit.slope,
                    r.report.verdict().c_str());
    }

    // Time to a relative RMSE (RMSE / mean reference radiance), and the ratio to the first.
    std::printf("\n%-14s", "rel. RMSE");
    std::vector<std::string> tte_header{"rel. RMSE"};
    std::vector<std::vector<std::string>> tte_rows;
    for (const Run& r : runs) {
        std::printf(" %-34.34s", (r.backend + ": " + r.device).c_str());
        tte_header.push_back(r.backend + ": " + r.device);
    }
    std::printf("\n");
    for (double target : a.targets) {
        char head[32];
        std::snprintf(head, sizeof head, "%.3g%%", 100 * target);
        std::printf("%-14s", head);
        tte_rows.push_back({head});
        double first = 0;
        for (size_t i = 0; i < runs.size(); ++i) {
            const TimeToError t = time_to_error(runs[i].checkpoints, target, runs[i].report);
            std::string cell = t.text();
            if (i == 0)
                first = t.seconds;
            else if (first > 0 && t.seconds > 0) {
                char ratio[48];
                std::snprintf(ratio, sizeof ratio, " (x%.2f)", t.seconds / first);
                cell += ratio;
            }
            std::printf(" %-34s", cell.c_str());
            tte_rows.back().push_back(cell);
        }
        std::printf("\n");
    }
    if (runs.size() > 1) std::printf("(xN: time relative to %s)\n", runs[0].backend.c_str());

    // Files.
    write_csv(a.output + ".csv", runs);
    write_svg(a.output + ".svg", make_plot(label, runs));
    std::printf("\nwrote %s.csv, %s.svg\n", a.output.c_str(), a.output.c_str());
    if (!a.report.empty())
        write_converge_report(a, label, ref, runs, settings, tte_header, tte_rows);
}

}  // namespace

void add_converge_command(CLI::App& app) {
    auto a = std::make_shared<ConvergeArgs>();
    CLI::App* sub = app.add_subcommand("converge", "Error against run time, per backend");
    sub->add_option("scene", a->scene, "Built-in scene or .gltf/.glb file")->capture_default_str();
    add_lighting_options(sub, a->lighting);
    sub->add_option("--backend", a->backends, "opencl|vulkan[:device], repeatable")
        ->capture_default_str();
    sub->add_option("--device", a->devices,
                    "Device index or name, repeatable: each backend's run renders one image on "
                    "all of them (api:device mixes APIs)");
    sub->add_flag("--beside-one", a->beside_one,
                  "With several devices: also a run on the first alone, the curve beside");
    sub->add_option("--width", a->width)->check(CLI::Range(1, 16384))->capture_default_str();
    sub->add_option("--height", a->height)->check(CLI::Range(1, 16384))->capture_default_str();
    sub->add_option("--time", a->seconds, "Render time per backend (s)")
        ->check(CLI::Range(1e-3, 1e7))
        ->capture_default_str();
    sub->add_option("--spp", a->max_spp, "Also stop at this many samples per pixel")
        ->check(CLI::Range(int64_t(1), int64_t(1000000000000)));
    sub->add_option("--checkpoints", a->checkpoints,
                    "geometric (1, 2, 4, ... spp) or time (time budget / 2^k)")
        ->check(CLI::IsMember({"geometric", "time"}))
        ->capture_default_str();
    sub->add_option("--reference", a->reference,
                    "auto (exact when known, else cached), exact, or cached")
        ->check(CLI::IsMember({"auto", "exact", "cached"}))
        ->capture_default_str();
    sub->add_option("--reference-spp", a->reference_spp, "Samples per pixel of a new reference")
        ->check(CLI::Range(16, 100000000))
        ->capture_default_str();
    sub->add_option("--target-rmse", a->targets, "Relative RMSE targets for time-to-error")
        ->check(CLI::Range(1e-9, 10.0))
        ->capture_default_str();
    sub->add_option("--max-depth", a->max_depth, "Bounces (default 8, or the scene's)")
        ->check(CLI::Range(0, 1000000));
    sub->add_option("--tree", a->tree, std::string("Trace mode: ") + kTreeChoicesHelp)
        ->check(CLI::IsMember(tree_kind_names()))
        ->capture_default_str();
    sub->add_option(
           "--seed", a->seed,
           "Seed of the first run (each further run adds 100000; --beside-one's takes its twin's)")
        ->capture_default_str();
    sub->add_option("--sampler", a->samplers,
                    "sobol (Owen-scrambled Sobol) and/or independent, one run per backend each")
        ->check(CLI::IsMember({"sobol", "independent"}))
        ->capture_default_str();
    sub->add_option("--sampling", a->sampling,
                    "uniform and/or adaptive (samples where the estimated noise is), one run "
                    "per backend and sampler each")
        ->check(CLI::IsMember({"uniform", "adaptive"}))
        ->capture_default_str();
    sub->add_option("-o,--output", a->output, "Output prefix: prefix.csv, prefix.svg")
        ->capture_default_str();
    sub->add_option("--report", a->report,
                    "Also write a self-contained HTML report (plot, tables, images) to "
                    "DIR/index.html")
        ->type_name("DIR");
    sub->callback([a] { run_converge(*a); });
}

}  // namespace mcpt
