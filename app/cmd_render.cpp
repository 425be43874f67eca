// mcpt render: progressive rendering with a progress bar, throughput and per-pixel error.
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <memory>

#include "app/commands.h"
#include "app/mpi_job.h"
#include "common/error.h"
#include "common/io/image_io.h"
#include "common/render/parts.h"
#include "common/render/prepare.h"
#include "common/render/scene_features.h"
#include "common/render/session.h"
#include "common/scene/scene_load.h"
#include "common/view/tev_stream.h"

namespace mcpt {

namespace {

void print_progress(double frac, const RenderResult& r) {
    const int width = 30;
    const int filled = int(std::round(frac * width));
    const double paths = double(r.spp) * r.width * r.height;
    std::fprintf(stderr, "\r[%s%s] %3d%%  %6.1f s  %llu spp  %.2f M paths/s ",
                 std::string(size_t(filled), '#').c_str(),
                 std::string(size_t(width - filled), ' ').c_str(), int(frac * 100), r.seconds,
                 (unsigned long long)r.spp, r.seconds > 0 ? paths / r.seconds * 1e-6 : 0.0);
    std::fflush(stderr);
}

}  // namespace

void run_render(const RenderArgs& a) {
    // Device, scene, settings: the engine's session does the rest.
    BackendOptions bo;
    bo.fast_math = a.fast_math;
    bo.limits = a.limits;
    check_image_path(a.output);  // before anything renders
    // tev: the address is checked now; the stream connects in the background.
    std::unique_ptr<TevStream> tev;
    if (!a.display_server.empty())
        tev = std::make_unique<TevStream>(
            a.display_server, std::filesystem::path(a.output).filename().string(),
            [bar = !a.quiet && isatty(2)](const std::string& w) {
                // (From the stream's thread; off the progress bar's line.)
                std::fprintf(stderr, "%smcpt: warning: %s\n", bar ? "\n" : "", w.c_str());
            });
    // An MPI job: rank 0 holds the image, every rank renders chunks on its own device.
    const MpiJob& mpi = mpi_job();
    if (mpi.size > 1 && a.devices.size() > 1)
        throw Error("under mpirun each rank takes one device: give at most one --device");
    if (mpi.size > 1 && !a.part.empty()) throw Error("--part is for runs without mpirun");
    std::vector<std::string> specs = device_specs(a.backend, a.devices);
    if (mpi.size > 1 && a.devices.empty()) specs = {rank_device(a.backend, mpi)};
    Session session(specs, bo);
    const Environment env = lighting_environment(a.lighting);
    session.set_environment(env);
    Scene loaded = load_scene(a.scene);
    for (const std::string& w : loaded.warnings) std::cerr << "mcpt: warning: " << w << "\n";
    if (a.verbose && !loaded.extensions.empty())
        std::printf("glTF extensions: %s\n", extension_list(loaded).c_str());
    if (env.present()) loaded.environment = env;  // the light choice sees it
    apply_light_sampling(loaded, a.lighting);
    session.set_scene(std::move(loaded));
    SessionSettings& s = session.settings();
    s.width = a.width, s.height = a.height;
    s.max_depth = a.max_depth;
    s.tree = a.tree, s.tree_depth = a.depth;
    s.seed = a.seed;
    s.specialize = a.specialize == "on";
    s.sampler = a.sampler;
    s.reproducible = a.reproducible || !a.checkpoint.empty();
    s.adaptive = a.adaptive;
    s.chunk_seconds = a.chunk_seconds;
    if (!a.part.empty()) {
        uint32_t index = 0, count = 0;
        parse_part(a.part, index, count);
        if (a.checkpoint.empty())
            throw Error(
                "a part is written as a checkpoint: give --checkpoint FILE (mcpt merge "
                "adds the parts)");
        session.set_part(part_range(a.spp, index, count, kReproducibleGroupSpp));
    }
    // Ranks above 0 render what rank 0 hands out, and write nothing.
    if (mpi.rank > 0) {
        mpi_serve(session, a.reduction == "flat");
        return;
    }
    RankJob rank_job;
    rank_job.width = a.width, rank_job.height = a.height;
    rank_job.exact = s.reproducible;
    rank_job.timeout_floor_s = a.rank_timeout;
    rank_job.flat_reduction = a.reduction == "flat";
    for (auto& w : mpi_remote_workers(session.fingerprint(), rank_job))
        session.add_worker(std::move(w));
    session.commit();
    for (const std::string& w : session.prepared().warnings)
        std::cerr << "mcpt: warning: " << w << "\n";
    // Resume where an earlier run of this command stopped.
    if (!a.checkpoint.empty()) {
        std::error_code ec;
        if (std::filesystem::exists(a.checkpoint, ec)) {
            session.resume_checkpoint(a.checkpoint);
            std::printf("resumed from %s at %llu spp\n", a.checkpoint.c_str(),
                        (unsigned long long)session.spp());
        } else {
            // Its folder must take files: refuse now, not after the first interval.
            const std::filesystem::path folder = std::filesystem::path(a.checkpoint).parent_path();
            if (access(folder.empty() ? "." : folder.c_str(), W_OK) != 0)
                throw Error("cannot write checkpoint '" + a.checkpoint +
                            "': its folder does not exist or is not writable");
        }
    }
    const Scene& scene = session.scene();
    const GpuScene& g = session.prepared();
    std::printf("scene: %s: %zu triangles, %zu spheres, %zu materials, %u lights\n",
                scene.name.empty() ? a.scene.c_str() : scene.name.c_str(), scene.triangles.size(),
                scene.spheres.size(), scene.materials.size(), g.params.num_lights);
    // Lights that are not surfaces: the glTF file's lamps, the environment (as packed).
    std::string lamps;
    if (!scene.punctual_lights.empty())
        lamps = std::to_string(scene.punctual_lights.size()) + " lamps (KHR_lights_punctual)";
    if (scene.environment.present())
        lamps += (lamps.empty() ? "" : ", ") + std::string("environment ") +
                 scene.environment.name + " " + std::to_string(g.params.env_width) + "x" +
                 std::to_string(g.params.env_height);
    if (!lamps.empty()) std::printf("lights: %s\n", lamps.c_str());
    if (g.params.num_lights > 1)
        std::printf("light sampling: %s\n",
                    g.params.num_tree_lights > 0
                        ? ("the tree (" + std::to_string(g.params.num_tree_lights) +
                           " local lights, by their importance at the shading point)")
                              .c_str()
                    : (g.params.scene_flags & SCENE_LIGHT_CONTRIBUTION)
                        ? "by contribution (each lamp's unshadowed light at the shading point, "
                          "the BSDF included)"
                        : "by power");
    // How next-event estimation samples emissive triangles (--triangle-light-sampling).
    if (g.features & (FEATURE_TRIANGLE_LIGHTS | FEATURE_RECT_LIGHTS)) {
        using Tls = Scene::TriangleLightSampling;
        const Tls tls = scene.triangle_light_sampling;
        const char* how =
            tls == Tls::Area        ? "by area"
            : tls == Tls::Triangles ? "each by the solid angle it subtends, warped toward the "
                                      "receiver's cosine where it spans 0.2 sr or more"
            : tls == Tls::Uniform   ? "by solid angle, a rectangle's halves as one, uniformly"
            : tls == Tls::Cosine    ? "by solid angle, a rectangle's halves as one, warped toward "
                                      "the receiver's cosine"
                                    : "by solid angle, a rectangle's halves as one, warped toward "
                                      "the receiver's cosine where the light spans 0.2 sr or more";
        std::printf(
            "emissive triangles: %s%s\n", how,
            tls == Tls::Area ? "" : " (near their plane, tiny or far for their size: by area)");
    }
    if (a.verbose && !g.tree_choice.empty()) std::printf("%s\n", g.tree_choice.c_str());
    std::printf("tree: %s%s\n", a.tree == "auto" ? "auto, " : "", describe_tree(g).c_str());

    // Render in steps of a quarter second (or of the checkpoint interval, if shorter) until the
    // samples, the time or the error is there.
    uint64_t spp = a.part.empty() ? a.spp : session.part().end - session.part().first;
    double seconds = a.seconds;
    if (spp == 0 && seconds <= 0 && a.target_error <= 0) spp = 64;
    const bool bar = !a.quiet && isatty(2);
    const RenderResult& r = session.result();
    auto last_save = std::chrono::steady_clock::now();
    const auto save = [&] {
        if (a.checkpoint.empty() || session.spp() == 0) return;
        session.save_checkpoint(a.checkpoint);
        last_save = std::chrono::steady_clock::now();
    };
    RenderGoal goal;
    goal.spp = spp, goal.seconds = seconds, goal.target_error = a.target_error;
    // (Without a progress bar a step may be longer: each ends with a read-back.)
    goal.step_seconds =
        a.checkpoint.empty() ? (bar ? 0.25 : 1.0) : std::clamp(a.checkpoint_every, 1e-3, 0.25);
    const auto after_step = [&](const PassStats& st) {
        if (tev) tev->post(r.width, r.height, r.mean_image());
        if (std::chrono::duration<double>(std::chrono::steady_clock::now() - last_save).count() >=
            a.checkpoint_every)
            save();
        if (!bar) return;
        double frac = spp > 0       ? double(r.spp) / double(spp)
                      : seconds > 0 ? std::min(1.0, r.seconds / seconds)
                                    : 0.0;
        // With a target error, progress is also the fraction of the samples it needs.
        if (a.target_error > 0 && st.relative_error < HUGE_VAL)
            frac = std::max(frac, std::min(1.0, std::pow(a.target_error / st.relative_error, 2)));
        print_progress(frac, r);
    };
    PassStats st;
    try {
        st = render_until(session, goal, after_step);
    } catch (const Error& e) {
        // The device failed mid-render: the samples taken before are kept; write them.
        if (bar) std::fprintf(stderr, "\n");
        if (r.spp == 0)
            throw Error(std::string(e.what()) +
                        "\nno samples were kept: the device failed before its first samples "
                        "were read back; " +
                        a.output + " was not written");
        save();
        session.write_image(a.output);
        throw Error(std::string(e.what()) + "\nwrote the " + std::to_string(r.spp) +
                    " spp rendered before the failure to " + a.output);
    }
    if (bar) std::fprintf(stderr, "\n");
    save();
    // The final image to tev, completely, before the file is written.
    if (tev) {
        tev->post(r.width, r.height, r.mean_image());
        if (!tev->finish())
            std::fprintf(stderr,
                         "mcpt: warning: tev at %s: the final image was not sent within 5 s\n",
                         tev->address().c_str());
    }

    // Throughput and the error the image still carries.
    Backend& backend = session.backend();
    const double pixels = double(r.width) * r.height;
    const double paths = double(r.spp) * pixels;
    std::printf("device: %s (kernel build %.2f s)\n", backend.description().c_str(),
                backend.compile_seconds());
    // Several devices: what each took of the image.
    if (session.device_count() > 1)
        std::printf("%zu devices, %llu rounds; collecting their sums took %.3f s\n",
                    session.device_count(), (unsigned long long)session.rounds(),
                    session.collect_seconds());
    print_device_shares(session);
    if (a.verbose) {
        const ProgressiveRender* loop = session.loop();
        std::printf("%s layout: %s, submission budget %.0f ms\n", backend.device().backend.c_str(),
                    backend.layout().c_str(),
                    loop ? loop->dispatch_ms()
                         : dispatch_budget_ms(backend.device(), session.settings().dispatch_ms));
        if (loop) {
            std::printf("dispatches: %llu, longest %.1f ms (#%llu), median %.1f ms\n",
                        (unsigned long long)loop->dispatches(),
                        1e3 * loop->longest_dispatch_seconds(),
                        (unsigned long long)loop->longest_dispatch_number(),
                        1e3 * loop->median_dispatch_seconds());
        }
        if (session.readbacks() > 0)
            std::printf("read-backs to the host: %llu, %.3f s (%.1f%% of the render)\n",
                        (unsigned long long)session.readbacks(), session.readback_seconds(),
                        r.seconds > 0 ? 100.0 * session.readback_seconds() / r.seconds : 0.0);
        std::printf("features used: %s\n", feature_names(g.features).c_str());
        std::printf("compiled for: %s; left out: %s\n",
                    feature_names(backend.compiled_features()).c_str(),
                    features_left_out(backend.compiled_features()).c_str());
        // How rays are traced: trace sites and the BVH walk (backend.h).
        const uint32_t f = backend.compiled_features();
        const bool driver = traced_by_driver(g.tree_kind);
        const uint32_t walk = walk_steps(backend.device(), f, driver, g.stack_size - 1);
        std::printf("trace sites: %u; %s\n",
                    trace_sites(backend.device(), f, g.tree_kind == TreeKind::RayPipeline,
                                g.stack_size - 1),
                    walk > 0 ? ("BVH walked " + std::to_string(walk) +
                                " node steps at a time (MCPT_WALK_STEPS)")
                                   .c_str()
                             : "every ray walked whole");
    }
    std::printf(
        "rendered %dx%d, %llu spp, max depth %d in %.3f s: %.3f M samples/s, %.2f M rays/s\n",
        r.width, r.height, (unsigned long long)r.spp, session.max_depth(), r.seconds,
        paths / r.seconds * 1e-6, r.rays / r.seconds * 1e-6);
    const std::vector<float> err = r.std_error_image();
    double mean_err = 0, max_err = 0;
    for (float e : err) mean_err += e, max_err = std::max<double>(max_err, e);
    mean_err /= double(err.size());
    const double mean_l = r.mean_radiance();
    if (r.spp < 2) {
        // The sample variance needs two samples.
        std::printf("standard error per pixel: unknown with 1 sample per pixel (needs 2)\n");
    } else {
        std::printf(
            "standard error per pixel and channel (sample variance): mean %.4g, max "
            "%.4g; relative to mean radiance %.4g: %.2f%%\n",
            mean_err, max_err, mean_l, mean_l > 0 ? 100.0 * mean_err / mean_l : 0.0);
    }
    if (a.target_error > 0) {
        std::printf("target relative error %.2f%%: %s\n", 100 * a.target_error,
                    st.target_reached ? "reached" : "not reached (stopped by --time or --spp)");
    }
    if (r.nonfinite_total > 0) {
        std::printf(
            "WARNING: %llu invalid samples (NaN/Inf, or paths a device loop limit cut "
            "short) were counted and left out\n",
            (unsigned long long)r.nonfinite_total);
    } else {
        std::printf("non-finite samples: 0\n");
    }
    session.write_image(a.output);
    std::printf("wrote %s%s%s\n", a.output.c_str(), a.checkpoint.empty() ? "" : " and ",
                a.checkpoint.c_str());
}

}  // namespace mcpt
