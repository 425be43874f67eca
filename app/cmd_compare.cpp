// mcpt compare: render one scene on two backends and report speed side by side and whether
// the images agree, statistically (independent seeds) and with the same seed.
// Exit status: 0 agree, 2 differ, 1 error.
#include <array>
#include <chrono>
#include <cstdio>
#include <functional>
#include <future>
#include <thread>

#include "app/commands.h"
#include "app/mpi_job.h"
#include "common/analysis/compare.h"
#include "common/error.h"
#include "common/io/false_color.h"
#include "common/io/html_report.h"
#include "common/io/image_io.h"
#include "common/render/scene_features.h"

namespace mcpt {

namespace {

struct CompareArgs {
    std::string scene = "cornell";
    std::string b_scene;  // B renders this file instead (another encoding of the same scene)
    LightingArgs lighting;
    std::string a = "opencl", b = "vulkan";
    int width = 64, height = 64;
    int batches = 32;
    uint64_t spp = 4;
    uint64_t same_seed_spp = 4;
    double same_seed_limit = kSameSeedDivergedLimit;
    int max_depth = -1;
    std::string tree = "auto";
    double alpha = 0.01;
    std::string output;
    std::string report;  // folder of the HTML report (index.html)
    float b_light_scale = 1.f;
    std::string b_defines;
    bool parallel = false;  // A and B at once, each in a thread of its own
};

struct Side {
    std::unique_ptr<Session> session;  // renders the batches and the same-seed image
    // Several devices: the others, batches only, each opened and committed on a thread of its
    // own while the first renders; a device joins the batches when it is ready.
    std::vector<JoiningSession> joining;
    Backend& backend() const { return session->backend(); }
    BatchSet batches;
    RenderResult same_seed;
    double device_seconds = 0;  // of the batches, 0 if the device cannot time itself
    size_t devices = 1;         // rendering this side together
    std::string tree;           // the k-d tree it rendered with
    // Wall time of its steps: devices opened and kernels built, batches with the same-seed
    // render (on the first device, while the others start on batches), the same-seed render.
    double open_s = 0, batches_s = 0, same_seed_s = 0;
};

using SpeedRow = std::array<std::string, 3>;  // name, A, B

// The report: the speed table, both verdicts and their maps (--report DIR).
void write_compare_report(const CompareArgs& args, const Side (&sides)[2],
                          const std::vector<SpeedRow>& speed, const std::string& speed_ratio,
                          const Agreement& agreement, const DifferenceMaps& maps,
                          bool same_seed_agrees) {
    const bool agree = agreement.agree && same_seed_agrees;
    const int w = args.width, h = args.height;
    HtmlReport r("mcpt compare " + args.scene + ": " + (agree ? "AGREE" : "DIFFER"));
    // The overall verdict first, as the exit status has it.
    r.verdict(agree ? "AGREE" : "DIFFER", agree,
              std::string("statistical test ") + (agreement.agree ? "AGREE" : "DIFFER") +
                  ", same-seed test " + (same_seed_agrees ? "AGREE" : "DIFFER") + " (exit status " +
                  (agree ? "0" : "2") + ")",
              "overall");
    char line[256];
    std::snprintf(line, sizeof line,
                  "Scene %s, %dx%d, %d batches x %llu spp per backend, same seed at %llu spp.",
                  args.scene.c_str(), w, h, args.batches, (unsigned long long)args.spp,
                  (unsigned long long)args.same_seed_spp);
    r.paragraph(line);

    // Speed, the rows the command prints.
    r.heading("Speed");
    std::vector<std::vector<std::string>> rows;
    for (const SpeedRow& s : speed) rows.push_back({s[0], s[1], s[2]});
    r.table({"", "A", "B"}, rows);
    r.paragraph(speed_ratio);

    // Statistical test: verdict, its numbers, the z map.
    r.heading("Statistical agreement (independent seeds)");
    const std::string v = agreement.verdict();
    r.verdict(agreement.agree ? "AGREE" : "DIFFER", agreement.agree, v.substr(v.find(": ") + 2));
    const auto num = [](const char* format, double x) {
        char b[64];
        std::snprintf(b, sizeof b, format, x);
        return std::string(b);
    };
    r.table(
        {"measure", "value"},
        {{"family-wise alpha", num("%.3g", args.alpha)},
         {"pixels tested", std::to_string(agreement.pixels_tested)},
         {"mean radiance B vs A", num("%+.3f%%", 100 * agreement.mean_relative_diff)},
         {"min p (Sidak level)",
          num("%.3g", agreement.min_p) + " (" + num("%.3g", agreement.sidak_level) + ")"},
         {"pixels below the Sidak level", std::to_string(agreement.sidak_rejections)},
         {"Benjamini-Hochberg discoveries", std::to_string(agreement.bh_discoveries)},
         {"mean z score (limit +-" + num("%.3g", agreement.global_z_limit) + ")",
          num("%.3f", agreement.mean_z_score)},
         {"chi2 z score (limit " + num("%.3g", agreement.global_z_limit) + ")",
          num("%.3f", agreement.chi2_score)},
         {"uniform bias detected with 90% power", num("%.3g%%", 100 * agreement.detectable_bias)},
         {"non-finite samples A, B", std::to_string(sides[0].batches.nonfinite) + ", " +
                                         std::to_string(sides[1].batches.nonfinite)}});
    r.images({{w, h, false_color_pixels(agreement.z_image, z_color),
               "Per-pixel Welch z of B - A over the batch means: white 0, red B brighter, blue B "
               "darker, full colour at |z| >= 5; magenta not finite"}});

    // Same seed: verdict, both images, the relative difference and its z.
    r.heading("Same seed");
    const SameSeedDiff& d = maps.same_seed;
    std::snprintf(line, sizeof line,
                  "%zu of %zu pixels diverged (> %.0e relative), %.3f%% (limit %.3g%%); max "
                  "|difference| %.3g",
                  d.diverged, d.pixels, d.tolerance, 100 * d.fraction_diverged(),
                  100 * args.same_seed_limit, d.max_abs_diff);
    r.verdict(same_seed_agrees ? "AGREE" : "DIFFER", same_seed_agrees, line);
    // The relative map log-scaled: 1e-4 x tolerance (black) to 100 x tolerance (white-ish).
    const float lo = float(d.tolerance * 1e-4), hi = float(d.tolerance * 1e2);
    // Both images at A's exposure, so that a brighter B looks brighter.
    const float exposure = display_exposure(sides[0].same_seed.mean_radiance());
    std::snprintf(line, sizeof line, " (sRGB, exposure %.3g)", exposure);
    const std::string shown = line;
    std::snprintf(line, sizeof line,
                  "Relative difference max over channels |B - A| / max(|A|, |B|, 1e-3), log "
                  "scale: black <= %.0e, the tolerance %.0e at 2/3, white >= %.0e",
                  lo, d.tolerance, hi);
    r.images({{w, h, radiance_to_srgb8(sides[0].same_seed.mean_image(), exposure),
               "A: " + sides[0].backend().description() + shown},
              {w, h, radiance_to_srgb8(sides[1].same_seed.mean_image(), exposure),
               "B: " + sides[1].backend().description() + shown},
              {w, h,
               false_color_pixels(maps.relative,
                                  [&](float x) { return sequential_color(log_unit(x, lo, hi)); }),
               line},
              {w, h, false_color_pixels(maps.z, z_color),
               "z of B - A from each side's sample standard error (conservative with shared "
               "samples): white 0, red B brighter, blue B darker, full colour at |z| >= 5"}});
    r.write(args.report);
    std::printf("wrote %s/index.html\n", args.report.c_str());
}

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

void run_compare(const CompareArgs& args) {
    const auto start = std::chrono::steady_clock::now();
    const MpiJob& mpi = mpi_job();
    if (mpi.size > 1 && args.parallel)
        throw Error("under mpirun every rank renders A's batches, then B's: not with --parallel");
    if (mpi.rank == 0 && !args.report.empty()) prepare_report_dir(args.report);  // before rendering
    // A's scene, and B's (the same unless --b-scene names another file).
    Scene scenes[2];
    for (int s = 0; s < 2; ++s) {
        if (s == 1 && args.b_scene.empty()) {
            scenes[1] = scenes[0];
            break;
        }
        scenes[s] = load_scene_argument(s == 0 ? args.scene : args.b_scene);
        scenes[s].environment = lighting_environment(args.lighting);
        apply_light_sampling(scenes[s], args.lighting);
        check_lit(scenes[s]);
    }
    const Scene& scene = scenes[0];
    RenderOptions ro;
    ro.width = args.width, ro.height = args.height;
    ro.max_depth = uint32_t(args.max_depth >= 0 ? args.max_depth : default_max_depth(scene));
    BatchOptions bo;
    bo.batches = args.batches;
    bo.spp_per_batch = args.spp;

    const std::string specs[2] = {args.a, args.b};
    // A side's device options, and the settings each of its sessions renders with.
    const auto side_options = [&](int s) {
        BackendOptions opt;
        if (s == 1) opt.extra_defines = args.b_defines;
        return opt;
    };
    const auto configure = [&](Session& one, int s) {
        one.set_scene(scenes[s]);
        one.settings().width = args.width, one.settings().height = args.height;
        one.settings().max_depth = int(ro.max_depth);
        one.settings().light_scale = s == 1 ? args.b_light_scale : 1.f;
        // The tree: the side's tree= option, else --tree; auto: the one this side's device
        // cost model picks.
        const std::string side_tree = parse_device_spec(device_list(specs[s])[0]).tree;
        one.settings().tree = side_tree.empty() ? args.tree : side_tree;
    };
    // Ranks above 0 of an MPI job: A's batches, then B's, as rank 0 hands them out.
    if (mpi.rank > 0) {
        for (int s = 0; s < 2; ++s) {
            Session session(open_device(rank_side_device(specs[s], mpi), side_options(s)));
            configure(session, s);
            mpi_serve_batches(session);
        }
        return;
    }
    Side sides[2];
    const auto since = [](std::chrono::steady_clock::time_point t) {
        return std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
    };
    // A side's devices opened, its tree built and its kernels compiled: the first here, the
    // others on threads of their own, started once the first is open (drivers serialize
    // their start), to join its batches when ready.
    const auto prepare_side = [&](int s) {
        const BackendOptions opt = side_options(s);
        const std::vector<std::string> devices =
            mpi.size > 1 ? std::vector{rank_side_device(specs[s], mpi)} : device_list(specs[s]);
        const auto t0 = std::chrono::steady_clock::now();
        sides[s].session = std::make_unique<Session>(open_device(devices[0], opt));
        for (size_t k = 1; k < devices.size(); ++k) {
            const std::string device = devices[k];
            sides[s].joining.push_back({device, std::async(std::launch::async, [&, device, opt, s] {
                                                    auto one = std::make_shared<Session>(
                                                        open_device(device, opt));
                                                    configure(*one, s);
                                                    one->commit();
                                                    return one;
                                                }).share()});
        }
        sides[s].devices = devices.size();
        configure(*sides[s].session, s);
        sides[s].session->commit();
        sides[s].tree = tree_kind_name(sides[s].session->prepared().tree_kind);
        sides[s].open_s = since(t0);
    };
    // A side's batches (independent seeds) and its same-seed render.
    const auto render_side = [&](int s) {
        Session& session = *sides[s].session;
        // The same-seed image, on the first device while the others (if any) start on the
        // batches.
        double same_seed_device_s = 0;
        const auto same_seed = [&](Session& first) {
            const auto t2 = std::chrono::steady_clock::now();
            const double before = first.backend().device_seconds();
            first.settings().seed = 7;
            first.reset();
            RenderGoal goal;
            goal.spp = args.same_seed_spp;
            render_until(first, goal);
            sides[s].same_seed = first.result();
            same_seed_device_s = first.backend().device_seconds() - before;
            sides[s].same_seed_s = since(t2);
        };
        const auto t1 = std::chrono::steady_clock::now();
        BatchOptions side_bo = bo;
        side_bo.seed_base = 1000u + 100000u * uint32_t(s);
        const double device_before = session.backend().device_seconds();
        // Under mpirun the other ranks render batches too (each said it has the same job).
        std::vector<std::unique_ptr<BatchRenderer>> ranks;
        std::vector<BatchRenderer*> remote;
        if (mpi.size > 1) {
            RankJob rank_job;
            rank_job.width = args.width, rank_job.height = args.height;
            ranks = mpi_batch_renderers(session.fingerprint(), rank_job);
            for (auto& r : ranks) remote.push_back(r.get());
            sides[s].devices += ranks.size();
        }
        sides[s].batches = render_batches({&session}, side_bo, same_seed, remote, sides[s].joining);
        // (Several devices: only the first's timers are at hand; no device time then.)
        sides[s].device_seconds = sides[s].devices > 1 ? 0
                                                       : session.backend().device_seconds() -
                                                             device_before - same_seed_device_s;
        sides[s].batches_s = since(t1);
    };
    // Work for A and B in two threads; a failure of either is reported after both end.
    const auto on_both_sides = [](const std::function<void(int)>& work) {
        std::string failure[2];
        std::thread b([&] {
            try {
                work(1);
            } catch (const std::exception& e) {
                failure[1] = e.what();
            }
        });
        try {
            work(0);
        } catch (const std::exception& e) {
            failure[0] = e.what();
        }
        b.join();
        for (int s = 0; s < 2; ++s)
            if (!failure[s].empty()) throw Error(std::string(s ? "B: " : "A: ") + failure[s]);
    };
    if (args.parallel) {
        // A and B on their devices at once.
        on_both_sides([&](int s) { prepare_side(s), render_side(s); });
    } else {
        // Both sides' devices opened and compiled at once (a driver's start-up, a compiler's
        // run overlap), then A's batches, then B's: each side's speed its own.
        on_both_sides(prepare_side);
        render_side(0), render_side(1);
    }
    // Speed, side by side.
    const double pixels = double(args.width) * args.height;
    std::printf("scene %s%s, %dx%d, %d batches x %llu spp per backend, max depth %u\n",
                args.scene.c_str(),
                args.b_scene.empty() ? "" : (" (B: " + args.b_scene + ")").c_str(), args.width,
                args.height, args.batches, (unsigned long long)args.spp, ro.max_depth);
    std::printf("%-26s %-40s %-40s\n", "", "A", "B");
    std::vector<SpeedRow> speed;  // printed, and in the report
    const auto described = [&](const Side& side) {
        const std::string d = side.backend().description();
        return side.devices > 1 ? d + " (+" + std::to_string(side.devices - 1) + " more)" : d;
    };
    speed.push_back({"backend", described(sides[0]), described(sides[1])});
    // Several devices: how many batches each rendered (a device ready late renders fewer).
    const auto device_count = [](const Side& side) {
        std::string d = std::to_string(side.devices);
        const std::vector<int>& per = side.batches.per_device;
        if (per.size() > 1) {
            d += " (batches";
            for (size_t k = 0; k < per.size(); ++k) d += (k ? "+" : " ") + std::to_string(per[k]);
            d += ")";
        }
        return d;
    };
    speed.push_back({"devices", device_count(sides[0]), device_count(sides[1])});
    double rate[2];
    for (int s = 0; s < 2; ++s) {
        const BatchSet& bs = sides[s].batches;
        rate[s] = double(bs.batches) * double(bs.spp_per_batch) * pixels / bs.seconds;
    }
    auto row = [&](const char* name, double x, double y, const char* unit) {
        speed.push_back({name, std::to_string(x) + unit, std::to_string(y) + unit});
    };
    speed.push_back({"k-d tree", sides[0].tree, sides[1].tree});
    row("compile/pipeline (s)", sides[0].backend().compile_seconds(),
        sides[1].backend().compile_seconds(), "");
    row("time per sample (ns)", 1e9 / rate[0], 1e9 / rate[1], "");
    row("M samples/s", rate[0] * 1e-6, rate[1] * 1e-6, "");
    row("M rays/s", sides[0].batches.rays / sides[0].batches.seconds * 1e-6,
        sides[1].batches.rays / sides[1].batches.seconds * 1e-6, "");
    // Where the time goes: in the kernel (device timers) or around it (submission, waits,
    // read-back): a slower side with the same device time pays in host overhead.
    double device_ns[2], overhead[2];
    for (int s = 0; s < 2; ++s) {
        const BatchSet& bs = sides[s].batches;
        const double samples = double(bs.batches) * double(bs.spp_per_batch) * pixels;
        device_ns[s] = sides[s].device_seconds > 0 ? 1e9 * sides[s].device_seconds / samples : 0;
        overhead[s] =
            sides[s].device_seconds > 0 ? 100 * (1 - sides[s].device_seconds / bs.seconds) : 0;
    }
    row("device time/sample (ns)", device_ns[0], device_ns[1], "");
    row("host overhead (%)", overhead[0], overhead[1], "");
    for (const SpeedRow& s : speed)
        std::printf("%-26s %-40s %-40s\n", s[0].c_str(), s[1].c_str(), s[2].c_str());
    if (args.parallel)
        std::printf(
            "(A and B rendered at once: on devices that share a machine, their speeds "
            "are not each one's alone)\n");
    char ratio[128];
    int at = std::snprintf(ratio, sizeof ratio, "speed ratio B/A: %.3f", rate[1] / rate[0]);
    if (device_ns[0] > 0 && device_ns[1] > 0)
        std::snprintf(ratio + at, sizeof ratio - at, " (device time alone: %.3f)",
                      device_ns[0] / device_ns[1]);
    std::printf("%s\n", ratio);
    std::string speed_ratio = ratio;
    if (args.parallel) speed_ratio += " (A and B rendered at once)";

    // Statistical agreement.
    const auto tests_start = std::chrono::steady_clock::now();
    const Agreement agreement = test_agreement(sides[0].batches, sides[1].batches, args.alpha);
    std::printf("mean radiance B vs A: %+.3f%%\n", 100 * agreement.mean_relative_diff);
    std::printf("statistical (alpha %.3g, %zu pixels tested): %s\n", args.alpha,
                agreement.pixels_tested, agreement.verdict().c_str());
    if (sides[0].batches.nonfinite + sides[1].batches.nonfinite > 0) {
        std::printf("non-finite samples: A %llu, B %llu\n",
                    (unsigned long long)sides[0].batches.nonfinite,
                    (unsigned long long)sides[1].batches.nonfinite);
    }
    // Same-seed agreement.
    const DifferenceMaps maps = difference_maps(sides[0].same_seed, sides[1].same_seed);
    const SameSeedDiff& d = maps.same_seed;
    const bool same_seed_agrees = d.agree(args.same_seed_limit);
    std::printf(
        "same seed (%llu spp): %s: %zu of %zu pixels diverged (> %.0e relative), %.3f%% "
        "(limit %.3g%%); max |difference| %.3g\n",
        (unsigned long long)args.same_seed_spp, same_seed_agrees ? "AGREE" : "DIFFER", d.diverged,
        d.pixels, d.tolerance, 100 * d.fraction_diverged(), 100 * args.same_seed_limit,
        d.max_abs_diff);
    // Where the command's time went (wall time).
    const auto seconds_since = [](std::chrono::steady_clock::time_point t) {
        return std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
    };
    std::printf(
        "wall time (s): A open+compile %.2f, batches and same seed %.2f (same seed %.2f); B "
        "%.2f, %.2f (%.2f); tests %.2f; total %.2f\n",
        sides[0].open_s, sides[0].batches_s, sides[0].same_seed_s, sides[1].open_s,
        sides[1].batches_s, sides[1].same_seed_s, seconds_since(tests_start), seconds_since(start));
    if (!args.output.empty()) {
        // p-value, signed z (B - A), mean difference per pixel.
        std::vector<float> img(3 * agreement.p_image.size());
        for (size_t i = 0; i < agreement.p_image.size(); ++i) {
            img[3 * i] = agreement.p_image[i];
            img[3 * i + 1] = agreement.z_image[i];
            img[3 * i + 2] = float(sides[1].batches.mean[i] - sides[0].batches.mean[i]);
        }
        write_image(args.output, args.width, args.height, img);
        std::printf("wrote %s (R: p-value, G: z of B - A, B: mean difference)\n",
                    args.output.c_str());
    }
    // The report, whatever the verdict (before the exit status says it).
    if (!args.report.empty())
        write_compare_report(args, sides, speed, speed_ratio, agreement, maps, same_seed_agrees);
    // Either test can tell the images apart: the statistical one small biases in noisy pixels,
    // the same-seed one any change of the integrand beyond rounding.
    if (!agreement.agree || !same_seed_agrees) throw ExitStatus{2};
}

}  // namespace

void add_compare_command(CLI::App& app) {
    auto a = std::make_shared<CompareArgs>();
    CLI::App* sub = app.add_subcommand("compare", "A/B-test two backends on one scene");
    sub->add_option("scene", a->scene, "Built-in scene or .gltf/.glb file")->capture_default_str();
    add_lighting_options(sub, a->lighting);
    sub->add_option("--b-scene", a->b_scene,
                    "B renders this .gltf/.glb instead: the same scene in another encoding "
                    "(compressed, quantized); its camera and lights as the file has them");
    sub->add_option(
           "--a", a->a,
           "Backend A: opencl|vulkan[:device][,limits=phone][,tree=KIND]; several devices, "
           "comma-separated (opencl:0,opencl:1), render it together")
        ->capture_default_str();
    sub->add_option("--b", a->b, "Backend B, as --a")->capture_default_str();
    sub->add_option("--width", a->width)->check(CLI::Range(1, 4096))->capture_default_str();
    sub->add_option("--height", a->height)->check(CLI::Range(1, 4096))->capture_default_str();
    sub->add_option("--batches", a->batches, "Independent batches per backend")
        ->check(CLI::Range(2, 100000))
        ->capture_default_str();
    sub->add_option("--spp", a->spp, "Samples per pixel per batch")
        ->check(CLI::Range(1, 1000000))
        ->capture_default_str();
    sub->add_option("--same-seed-spp", a->same_seed_spp, "Samples per pixel of the same-seed test")
        ->check(CLI::Range(1, 1000000))
        ->capture_default_str();
    sub->add_option("--same-seed-limit", a->same_seed_limit,
                    "Fraction of pixels the same-seed renders may diverge in (rounding)")
        ->check(CLI::Range(0.0, 1.0))
        ->capture_default_str();
    sub->add_option("--max-depth", a->max_depth, "Bounces (default 8, or the scene's)");
    sub->add_option("--tree", a->tree,
                    std::string("Trace mode of both sides (a side's tree= option overrides): ") +
                        kTreeChoicesHelp)
        ->check(CLI::IsMember(tree_kind_names()))
        ->capture_default_str();
    sub->add_option("--alpha", a->alpha, "Family-wise false alarm rate")
        ->check(CLI::Range(1e-12, 0.5))
        ->capture_default_str();
    sub->add_option("-o,--output", a->output, "Write p-value / z / difference image (.exr)");
    sub->add_option(
           "--report", a->report,
           "Write a self-contained HTML report (verdicts, speed, images) to DIR/index.html")
        ->type_name("DIR");
    sub->add_flag("--parallel", a->parallel,
                  "Render A and B at once, each on its device (two GPUs: half the time)");
    sub->add_option("--b-light-scale", a->b_light_scale,
                    "Scale B's emitters (negative control: 1.02 must be detected)");
    sub->add_option("--b-defines", a->b_defines,
                    "Extra OpenCL defines for B (negative controls, e.g. "
                    "-DMCPT_NEGATIVE_CONTROL_NO_REFRACTION)");
    sub->callback([a] { run_compare(*a); });
}

}  // namespace mcpt
