// mcpt compare: render one scene on two backends and report speed side by side and whether
// the images agree, statistically (independent seeds) and with the same seed. A client of
// the engine's CompareJob (common/analysis/compare_job.h): arguments in, the result printed.
// Exit status: 0 agree, 2 differ, 1 error.
#include <cstdio>

#include "app/commands.h"
#include "app/mpi_job.h"
#include "common/analysis/compare_report.h"
#include "common/error.h"
#include "common/io/html_report.h"
#include "common/io/image_io.h"
#include "common/render/scene_features.h"

namespace mcpt {

namespace {

// Under mpirun each rank takes one device a side: the one the side names, or (the API alone)
// its GPU at its local rank (rank_device()).
std::string rank_side_device(const std::string& side, const MpiJob& mpi) {
    const std::vector<std::string> devices = device_list(side);
    if (devices.size() > 1)
        throw Error("under mpirun each rank takes one device a side: '" + side + "' names " +
                    std::to_string(devices.size()));
    const std::string& d = devices[0];
    const size_t comma = d.find(',');
    const std::string device = d.substr(0, comma);
    if (device.find(':') != std::string::npos) return d;
    return rank_device(device, mpi) + (comma == std::string::npos ? "" : d.substr(comma));
}

// The scene a side renders: --scene, or --b-scene's other encoding of it.
std::shared_ptr<const Scene> side_scene(const CompareArgs& args, const std::string& file) {
    auto scene = std::make_shared<Scene>(load_scene_argument(file));
    scene->environment = lighting_environment(args.lighting);
    apply_light_sampling(*scene, args.lighting);
    check_lit(*scene);
    return scene;
}

}  // namespace

void run_compare(const CompareArgs& args) {
    const MpiJob& mpi = mpi_job();
    if (mpi.size > 1 && args.parallel)
        throw Error("under mpirun every rank renders A's batches, then B's: not with --parallel");
    if (mpi.rank == 0 && !args.report.empty()) prepare_report_dir(args.report);  // before rendering
    // The job: the scene (B's another encoding with --b-scene), the sides and the plan.
    CompareSpec spec;
    spec.scene = side_scene(args, args.scene);
    const std::string sides[2] = {args.a, args.b};
    for (int s = 0; s < 2; ++s) {
        spec.sides[s] = compare_side(sides[s]);
        // Under mpirun: one device a side on every rank.
        if (mpi.size > 1) spec.sides[s].devices = {rank_side_device(sides[s], mpi)};
    }
    if (!args.b_scene.empty()) spec.sides[1].scene = side_scene(args, args.b_scene);
    spec.sides[1].light_scale = args.b_light_scale;
    spec.sides[1].extra_defines = args.b_defines;
    spec.width = args.width, spec.height = args.height;
    spec.batches = args.batches, spec.spp = args.spp;
    spec.same_seed_spp = args.same_seed_spp, spec.same_seed_limit = args.same_seed_limit;
    spec.max_depth = args.max_depth, spec.tree = args.tree, spec.alpha = args.alpha;
    spec.parallel = args.parallel;
    // Ranks above 0 of an MPI job: A's batches, then B's, as rank 0 hands them out.
    if (mpi.rank > 0) {
        const uint32_t max_depth =
            uint32_t(args.max_depth >= 0 ? args.max_depth : default_max_depth(*spec.scene));
        for (int s = 0; s < 2; ++s) {
            BackendOptions opt;
            opt.extra_defines = spec.sides[s].extra_defines;
            Session session(open_device(spec.sides[s].devices[0], opt));
            session.set_scene(spec.sides[s].scene ? *spec.sides[s].scene : *spec.scene);
            session.settings().width = args.width, session.settings().height = args.height;
            session.settings().max_depth = int(max_depth);
            session.settings().light_scale = spec.sides[s].light_scale;
            session.settings().tree = spec.sides[s].tree.empty() ? args.tree : spec.sides[s].tree;
            mpi_serve_batches(session);
        }
        return;
    }
    // Rank 0 of an MPI job: the other ranks render batches too (each said it has the same job).
    if (mpi.size > 1)
        spec.remote = [&](Session& first, int) {
            RankJob rank_job;
            rank_job.width = args.width, rank_job.height = args.height;
            return mpi_batch_renderers(first.fingerprint(), rank_job);
        };
    const CompareResult r = CompareJob(std::move(spec)).run();

    // Speed, side by side.
    std::printf("scene %s%s, %dx%d, %d batches x %llu spp per backend, max depth %u\n",
                args.scene.c_str(),
                args.b_scene.empty() ? "" : (" (B: " + args.b_scene + ")").c_str(), args.width,
                args.height, args.batches, (unsigned long long)args.spp, r.max_depth);
    std::printf("%-26s %-40s %-40s\n", "", "A", "B");
    for (const SpeedRow& s : compare_speed_rows(r))
        std::printf("%-26s %-40s %-40s\n", s[0].c_str(), s[1].c_str(), s[2].c_str());
    if (args.parallel)
        std::printf(
            "(A and B rendered at once: on devices that share a machine, their speeds "
            "are not each one's alone)\n");
    std::printf("%s\n", compare_speed_ratio(r).c_str());

    // Statistical agreement.
    const Agreement& agreement = r.agreement;
    std::printf("mean radiance B vs A: %+.3f%%\n", 100 * agreement.mean_relative_diff);
    std::printf("statistical (alpha %.3g, %zu pixels tested): %s\n", args.alpha,
                agreement.pixels_tested, agreement.verdict().c_str());
    const CompareSideResult(&sides_done)[2] = r.sides;
    if (sides_done[0].batches.nonfinite + sides_done[1].batches.nonfinite > 0) {
        std::printf("non-finite samples: A %llu, B %llu\n",
                    (unsigned long long)sides_done[0].batches.nonfinite,
                    (unsigned long long)sides_done[1].batches.nonfinite);
    }
    // Same-seed agreement.
    std::printf("%s\n", same_seed_line(r).c_str());
    // Where the command's time went (wall time).
    std::printf(
        "wall time (s): A open+compile %.2f, batches and same seed %.2f (same seed %.2f); B "
        "%.2f, %.2f (%.2f); tests %.2f; total %.2f\n",
        sides_done[0].open_s, sides_done[0].batches_s, sides_done[0].same_seed_s,
        sides_done[1].open_s, sides_done[1].batches_s, sides_done[1].same_seed_s, r.tests_s,
        r.total_s);
    if (!args.output.empty()) {
        write_image(args.output, args.width, args.height, compare_test_map(r));
        std::printf("wrote %s (R: p-value, G: z of B - A, B: mean difference)\n",
                    args.output.c_str());
    }
    // The report, whatever the verdict (before the exit status says it).
    if (!args.report.empty()) {
        write_compare_report(r, args.scene, args.report);
        std::printf("wrote %s/index.html\n", args.report.c_str());
    }
    // Either test can tell the images apart: the statistical one small biases in noisy pixels,
    // the same-seed one any change of the integrand beyond rounding.
    if (!r.agree()) throw ExitStatus{2};
}

}  // namespace mcpt
