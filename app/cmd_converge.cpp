// mcpt converge: error against run time. Renders progressively on each backend as independent
// batches, measures RMSE, relative MSE and mean signed error against a reference at
// geometrically spaced checkpoints, fits the log-log convergence rate, flags bias, and reports
// the time each backend needs to reach a relative RMSE. Writes prefix.csv and prefix.svg, and
// with --report DIR a self-contained HTML report. A client of the engine's ConvergeJob
// (common/analysis/converge_job.h): arguments in, the result printed and written.
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>

#include "app/commands.h"
#include "app/mpi_job.h"
#include "common/analysis/converge_report.h"
#include "common/error.h"
#include "common/io/html_report.h"

namespace mcpt {

namespace {

std::string scene_label(const Scene& scene, const std::string& arg) {
    if (!scene.name.empty()) return scene.name;
    return std::filesystem::path(arg).stem().string();
}

void print_checkpoint(const ConvergeRun& run, const Checkpoint& c) {
    std::printf("%-18s %-28.28s %9.3f %8llu %11.4g %8.2f%% %11.4g %+12.4g\n", run.backend.c_str(),
                run.device.c_str(), c.seconds, (unsigned long long)c.spp, c.error.rmse,
                100 * c.error.rel_rmse, c.error.rel_mse, c.error.mean_signed_error);
    std::fflush(stdout);
}

// Each backend's runs: on its --device list (one image on several devices, coordinator.h), and
// with --beside-one on the first of them alone too (what the others add). Under mpirun each
// rank takes one device (rank_device(), or the one --device), and --beside-one's run is rank
// 0's alone. Every rank computes the same list from the same arguments.
std::vector<ConvergeDevices> converge_runs(const ConvergeArgs& a, const MpiJob& mpi) {
    if (mpi.size <= 1) return converge_devices(a.backends, a.devices, a.beside_one);
    std::vector<ConvergeDevices> runs;
    for (const std::string& backend : a.backends) {
        const std::string spec =
            a.devices.empty() ? rank_device(backend, mpi) : device_specs(backend, a.devices)[0];
        if (a.beside_one) runs.push_back({{spec}, false, true});
        runs.push_back({{spec}, true, false});
    }
    return runs;
}

}  // namespace

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
    // The job: the scene, the runs, the schedule and the reference.
    ConvergeSpec spec;
    auto scene = std::make_shared<Scene>(load_scene_argument(a.scene));
    scene->environment = lighting_environment(a.lighting);
    apply_light_sampling(*scene, a.lighting);
    check_lit(*scene);
    spec.label = scene_label(*scene, a.scene);
    spec.scene = scene;
    spec.runs = converge_runs(a, mpi);
    spec.width = a.width, spec.height = a.height;
    spec.seconds = a.seconds, spec.max_spp = a.max_spp;
    spec.schedule = a.checkpoints == "time" ? Schedule::TimeDoubling : Schedule::SppDoubling;
    spec.reference = a.reference, spec.reference_spp = a.reference_spp;
    spec.reference_device = a.backends[0];
    spec.targets = a.targets;
    spec.max_depth = a.max_depth, spec.tree = a.tree, spec.seed = a.seed;
    spec.samplers = a.samplers, spec.sampling = a.sampling;
    spec.keep_images = !a.report.empty();
    if (mpi.rank > 0) {
        // Ranks above 0 of an MPI job: each run that has ranks, rendered as rank 0 hands it out.
        ConvergeJob(std::move(spec)).serve([](Session& s) { mpi_serve(s, false); });
        return;
    }
    // What the job says as it goes: the reference, the settings, each checkpoint.
    const bool bar = isatty(2);
    bool rendering_reference = false;
    spec.on_reference = [&](const std::string& message) {
        std::printf("%s\n", message.c_str());
        std::fflush(stdout);
        rendering_reference = true;
    };
    if (bar)
        spec.reference_progress = [](double f, double seconds) {
            std::fprintf(stderr, "\r  reference %3d%%  %.0f s ", int(100 * f), seconds);
        };
    spec.on_ready = [&](const ConvergeResult& r) {
        if (bar && rendering_reference) std::fprintf(stderr, "\n");
        std::printf("%s\n", r.settings.c_str());
        const Reference& ref = r.reference;
        std::printf("reference: %s; mean radiance %.4g\n", ref.source.c_str(), ref.mean_value());
        if (!ref.exact()) {
            std::printf(
                "reference noise: RMS standard error %.4g (%.2f%% of the mean); its variance "
                "is subtracted from every MSE below\n",
                std::sqrt(ref.noise_variance()),
                100 * std::sqrt(ref.noise_variance()) / ref.mean_value());
        }
        std::printf("\n%-18s %-28s %9s %8s %11s %9s %11s %12s\n", "backend", "device", "seconds",
                    "spp", "rmse", "rel rmse", "rel mse", "mean signed");
    };
    spec.on_checkpoint = print_checkpoint;
    // What the checkpoints cost in render time: read-backs (one device) or rounds whose sums
    // are collected (several).
    spec.on_run_end = [](const ConvergeRun& run, const Session& session) {
        if (run.devices > 1) {
            std::printf("  %llu rounds, %.3f s collecting their sums\n",
                        (unsigned long long)session.rounds(), session.collect_seconds());
            print_device_shares(session);
        } else
            std::printf("  %llu read-backs, %.3f s\n", (unsigned long long)session.readbacks(),
                        session.readback_seconds());
    };
    // Under mpirun: the other ranks join each run (each said it has the same job).
    if (mpi.size > 1)
        spec.remote = [&a](Session& session) {
            RankJob rank_job;
            rank_job.width = a.width, rank_job.height = a.height;
            return mpi_remote_workers(session.fingerprint(), rank_job);
        };
    const ConvergeResult result = ConvergeJob(std::move(spec)).run();

    // Fits and bias.
    std::printf("\n");
    for (const ConvergeRun& r : result.runs) {
        std::printf("%s %s: RMSE ~ time^%.3f, ~ spp^%.3f; %s\n", r.backend.c_str(),
                    r.device.c_str(), r.report.time_fit.slope, r.report.spp_fit.slope,
                    r.report.verdict().c_str());
    }

    // Time to a relative RMSE (RMSE / mean reference radiance), and the ratio to the first.
    const std::vector<std::string> header = time_to_error_header(result);
    std::printf("\n%-14s", header[0].c_str());
    for (size_t i = 1; i < header.size(); ++i) std::printf(" %-34.34s", header[i].c_str());
    std::printf("\n");
    for (const std::vector<std::string>& row : time_to_error_rows(result)) {
        std::printf("%-14s", row[0].c_str());
        for (size_t i = 1; i < row.size(); ++i) std::printf(" %-34s", row[i].c_str());
        std::printf("\n");
    }
    if (result.runs.size() > 1)
        std::printf("(xN: time relative to %s)\n", result.runs[0].backend.c_str());

    // Files.
    write_converge_csv(a.output + ".csv", result);
    write_svg(a.output + ".svg", converge_plot(result));
    std::printf("\nwrote %s.csv, %s.svg\n", a.output.c_str(), a.output.c_str());
    if (!a.report.empty()) {
        write_converge_report(result, a.report);
        std::printf("wrote %s/index.html\n", a.report.c_str());
    }
}

}  // namespace mcpt
