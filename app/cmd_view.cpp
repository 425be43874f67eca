// mcpt view: renders a scene (or A and B side by side) and serves a page on 127.0.0.1 that
// shows it converging: the image, its error, and for A/B the maps of their difference. The
// address it prints carries the run's token, which every request needs (view_access.h).
#include <chrono>
#include <csignal>
#include <cstdio>
#include <memory>
#include <thread>

#include "app/commands.h"
#include "app/mpi_job.h"
#include "app/view/view_server.h"
#include "common/error.h"
#include "common/render/session.h"
#include "common/view/live_render.h"

namespace mcpt {

namespace {

std::atomic<bool> g_interrupted{false};
extern "C" void on_interrupt(int) {
    g_interrupted.store(true);
}

// A side's session: its devices, the scene and the view's settings (every rank of an MPI job
// builds the same, so each greets rank 0 with the job's fingerprint), compiled now: errors
// before the server starts.
std::unique_ptr<Session> open_view_session(const std::vector<std::string>& spec, const Scene& scene,
                                           const Environment& env, const ViewArgs& args,
                                           bool side_b) {
    auto session = std::make_unique<Session>(spec, BackendOptions{});
    session->set_environment(env);
    session->set_scene(scene);
    SessionSettings& st = session->settings();
    st.width = args.width, st.height = args.height;
    // The side's tree= option (an A/B of trace modes), else --tree.
    const std::string side_tree = parse_device_spec(spec.at(0)).tree;
    st.seed = args.seed, st.max_depth = args.max_depth;
    st.tree = side_tree.empty() ? args.tree : side_tree;
    if (side_b) st.light_scale = args.b_light_scale;
    session->commit();
    return session;
}

}  // namespace

void run_view(const ViewArgs& args) {
    if (args.a.empty() != args.b.empty()) throw Error("an A/B view needs both --a and --b");
    const bool ab = !args.a.empty();
    // Under mpirun: one image on every rank's device (rank 0 serves the page, hands out the
    // chunks and collects the sums; pause and reset are rank 0's alone: the ranks render
    // whatever chunks come).
    const MpiJob& mpi = mpi_job();
    if (mpi.size > 1 && ab)
        throw Error(
            "an A/B view runs in one process (each side's devices with --a and --b), not under "
            "mpirun; under mpirun view renders one image on every rank");
    if (mpi.size > 1 && args.devices.size() > 1)
        throw Error("under mpirun each rank takes one device: give at most one --device");
    // One session per side, the same scene, settings and seed.
    // Each side's devices: one, or several rendering its image together (coordinator.h).
    std::vector<std::vector<std::string>> specs;
    if (ab)
        specs = {device_list(args.a), device_list(args.b)};
    else if (mpi.size > 1)
        specs = {{args.devices.empty() ? rank_device(args.backend, mpi) : args.devices[0]}};
    else
        specs = {device_specs(args.backend, args.devices)};
    Scene scene = load_scene_argument(args.scene);
    const Environment env = lighting_environment(args.lighting);
    if (env.present()) scene.environment = env;  // the light choice sees it
    apply_light_sampling(scene, args.lighting);
    if (mpi.rank > 0) {
        // Ranks above 0: the chunks rank 0 hands out, until it says stop. mpirun passes a
        // Ctrl-C on to every rank as SIGTERM (SIGKILL a few seconds later): rank 0 stops the
        // view and tells the ranks, which then end cleanly.
        std::signal(SIGINT, SIG_IGN);
        std::signal(SIGTERM, SIG_IGN);
        mpi_serve(*open_view_session(specs[0], scene, env, args, false), false);
        return;
    }
    std::vector<std::unique_ptr<Session>> sessions;
    ViewInfo info;
    info.scene = scene.name.empty() ? args.scene : scene.name;
    for (size_t s = 0; s < specs.size(); ++s) {
        std::unique_ptr<Session> session = open_view_session(specs[s], scene, env, args, s == 1);
        info.sides[s] = (ab ? std::string(s ? "B: " : "A: ") : "") + session->device().label();
        if (specs[s].size() > 1)
            info.sides[s] += " (+" + std::to_string(specs[s].size() - 1) + " more devices)";
        if (mpi.size > 1) {
            // The other ranks join (each said it has the same job); they stop with the session.
            RankJob rank_job;
            rank_job.width = args.width, rank_job.height = args.height;
            for (auto& w : mpi_remote_workers(session->fingerprint(), rank_job))
                session->add_worker(std::move(w));
            info.sides[s] += " (+" + std::to_string(mpi.size - 1) + " ranks)";
        }
        std::printf("%s\n", info.sides[s].c_str());
        sessions.push_back(std::move(session));
    }
    LiveRender live(std::move(sessions), args.spp);
    ViewServer server(live, info, args.listen);
    const int port = server.bind(args.port);
    if (!ViewAccess::is_loopback(args.listen))
        std::fprintf(stderr,
                     "mcpt: warning: --listen %s serves the viewer beyond this machine: whoever "
                     "can reach port %d and learns the token (it travels unencrypted, over "
                     "plain HTTP) can watch, pause, reset and download this render. An SSH "
                     "tunnel to 127.0.0.1 keeps it private (README, mcpt view).\n",
                     args.listen.c_str(), port);
    std::printf("mcpt view: %s (Ctrl-C stops)\n", server.url().c_str());
    std::fflush(stdout);
    // Render and serve, each on threads of their own, until Ctrl-C or the time is up.
    live.start();
    std::signal(SIGPIPE, SIG_IGN);  // a viewer that goes away mid-frame ends only its request
    std::thread serving([&] { server.serve(); });
    std::signal(SIGINT, on_interrupt);
    std::signal(SIGTERM, on_interrupt);
    const auto start = std::chrono::steady_clock::now();
    while (!g_interrupted.load()) {
        std::this_thread::sleep_for(std::chrono::milliseconds(50));
        const double t =
            std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
        if (args.seconds > 0 && t >= args.seconds) break;
    }
    const double wall =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    live.stop();
    server.stop();
    serving.join();
    std::signal(SIGINT, SIG_DFL);
    std::signal(SIGTERM, SIG_DFL);
    // What each side rendered, and how many frames the viewers took.
    for (size_t s = 0; s < live.sides(); ++s) {
        const RenderResult& r = live.session(s).result();
        const double paths = double(r.spp) * r.width * r.height;
        std::printf(
            "%s: %llu spp in %.2f s: %.3f M samples/s, %.2f M rays/s; over the %.2f s the "
            "viewer ran: %.3f M samples/s\n",
            info.sides[s].c_str(), (unsigned long long)r.spp, r.seconds,
            r.seconds > 0 ? paths / r.seconds * 1e-6 : 0.0,
            r.seconds > 0 ? r.rays / r.seconds * 1e-6 : 0.0, wall, paths / wall * 1e-6);
        if (live.session(s).device_stats().size() > 1) print_device_shares(live.session(s));
    }
    std::printf("frames sent: %llu in %.1f s (%.2f per second)\n",
                (unsigned long long)server.frames_sent(), wall,
                wall > 0 ? double(server.frames_sent()) / wall : 0.0);
    if (!live.failure().empty()) throw Error(live.failure());
}

}  // namespace mcpt
