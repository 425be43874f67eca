#include "common/analysis/compare_job.h"

#include <chrono>
#include <future>
#include <thread>

#include "common/accel/kdtree.h"
#include "common/error.h"
#include "common/render/device_registry.h"
#include "common/scene/scene_load.h"

namespace mcpt {

namespace {

using Clock = std::chrono::steady_clock;

double since(Clock::time_point t) {
    return std::chrono::duration<double>(Clock::now() - t).count();
}

// A side while it runs: its sessions, then what it produced.
struct Side {
    std::unique_ptr<Session> session;  // renders the batches and the same-seed image
    // Several devices: the others, batches only, each opened and committed on a thread of its
    // own while the first renders; a device joins the batches when it is ready.
    std::vector<JoiningSession> joining;
    CompareSideResult result;
};

// Work for A and B in two threads; a failure of either is reported after both end.
void on_both_sides(const std::function<void(int)>& work) {
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
}

}  // namespace

double CompareSideResult::samples_per_second() const {
    const BatchSet& b = batches;
    if (b.batches == 0 || !(b.seconds > 0)) return 0;
    return double(b.batches) * double(b.spp_per_batch) * double(b.width) * b.height / b.seconds;
}

double CompareSideResult::rays_per_second() const {
    return batches.seconds > 0 ? batches.rays / batches.seconds : 0;
}

double CompareSideResult::device_ns_per_sample() const {
    const double samples = double(batches.batches) * double(batches.spp_per_batch) *
                           double(batches.width) * batches.height;
    return device_seconds > 0 && samples > 0 ? 1e9 * device_seconds / samples : 0;
}

double CompareSideResult::host_overhead() const {
    return device_seconds > 0 && batches.seconds > 0 ? 1 - device_seconds / batches.seconds : 0;
}

double CompareResult::speed_ratio() const {
    const double a = sides[0].samples_per_second();
    return a > 0 ? sides[1].samples_per_second() / a : 0;
}

CompareSideSpec compare_side(const std::string& side) {
    CompareSideSpec spec;
    spec.devices = device_list(side);
    spec.tree = parse_device_spec(spec.devices[0]).tree;
    return spec;
}

CompareJob::CompareJob(CompareSpec spec) : spec_(std::move(spec)) {
    if (!spec_.scene) throw Error("compare: no scene");
    if (spec_.batches < 2) throw Error("compare: two batches a side at least");
    if (spec_.spp == 0 || spec_.same_seed_spp == 0)
        throw Error("compare: samples per pixel must be positive");
    if (spec_.width < 1 || spec_.height < 1) throw Error("compare: an empty image");
    if (!(spec_.alpha > 0 && spec_.alpha < 1)) throw Error("compare: alpha must be in (0, 1)");
    for (int s = 0; s < 2; ++s)
        if (spec_.sides[s].devices.empty())
            throw Error(std::string("compare: side ") + (s ? "B" : "A") + " has no device");
}

CompareResult CompareJob::run() {
    const auto start = Clock::now();
    const CompareSpec& spec = spec_;
    const Scene* scenes[2];
    for (int s = 0; s < 2; ++s)
        scenes[s] = spec.sides[s].scene ? spec.sides[s].scene.get() : spec.scene.get();
    CompareResult out;
    out.width = spec.width, out.height = spec.height;
    out.batches = spec.batches, out.spp = spec.spp, out.same_seed_spp = spec.same_seed_spp;
    out.same_seed_limit = spec.same_seed_limit, out.alpha = spec.alpha;
    out.parallel = spec.parallel;
    out.max_depth = uint32_t(spec.max_depth >= 0 ? spec.max_depth : default_max_depth(*scenes[0]));

    // A side's device options, and the settings each of its sessions renders with.
    const auto side_options = [&](int s) {
        BackendOptions opt;
        opt.extra_defines = spec.sides[s].extra_defines;
        return opt;
    };
    const auto configure = [&](Session& one, int s) {
        one.set_scene(*scenes[s]);
        one.settings().width = spec.width, one.settings().height = spec.height;
        one.settings().max_depth = int(out.max_depth);
        one.settings().light_scale = spec.sides[s].light_scale;
        // The side's tree, else the job's; auto: the one this side's device cost model picks.
        one.settings().tree = spec.sides[s].tree.empty() ? spec.tree : spec.sides[s].tree;
    };
    Side sides[2];
    // A side's devices opened, its tree built and its kernels compiled: the first here, the
    // others on threads of their own, started once the first is open (drivers serialize
    // their start), to join its batches when ready.
    const auto prepare_side = [&](int s) {
        const BackendOptions opt = side_options(s);
        const std::vector<std::string>& devices = spec.sides[s].devices;
        const auto t0 = Clock::now();
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
        CompareSideResult& r = sides[s].result;
        r.devices = devices.size();
        configure(*sides[s].session, s);
        sides[s].session->commit();
        r.tree = tree_kind_name(sides[s].session->prepared().tree_kind);
        r.open_s = since(t0);
    };
    // A side's batches (independent seeds) and its same-seed render.
    const auto render_side = [&](int s) {
        Session& session = *sides[s].session;
        CompareSideResult& r = sides[s].result;
        // The same-seed image, on the first device while the others (if any) start on the
        // batches.
        double same_seed_device_s = 0;
        const auto same_seed = [&](Session& first) {
            if (cancel_.load()) return;
            const auto t2 = Clock::now();
            const double before = first.backend().device_seconds();
            first.settings().seed = 7;
            first.reset();
            RenderGoal goal;
            goal.spp = spec.same_seed_spp;
            goal.cancel = &cancel_;
            render_until(first, goal);
            if (first.spp() < spec.same_seed_spp) return;  // cancelled
            r.same_seed = first.result();
            r.same_seed_done = true;
            same_seed_device_s = first.backend().device_seconds() - before;
            r.same_seed_s = since(t2);
        };
        const auto t1 = Clock::now();
        BatchOptions bo;
        bo.batches = spec.batches;
        bo.spp_per_batch = spec.spp;
        bo.seed_base = 1000u + 100000u * uint32_t(s);
        bo.cancel = &cancel_;
        if (spec.on_batch) bo.on_batch = [&spec, s] { spec.on_batch(s); };
        const double device_before = session.backend().device_seconds();
        // Devices elsewhere (MPI ranks) render batches too.
        std::vector<std::unique_ptr<BatchRenderer>> ranks;
        std::vector<BatchRenderer*> remote;
        if (spec.remote) {
            ranks = spec.remote(session, s);
            for (auto& rank : ranks) remote.push_back(rank.get());
            r.devices += ranks.size();
        }
        r.batches = render_batches({&session}, bo, same_seed, remote, sides[s].joining);
        r.batches_done = r.batches.batches;
        // (Several devices: only the first's timers are at hand; no device time then.)
        r.device_seconds =
            r.devices > 1 ? 0
                          : session.backend().device_seconds() - device_before - same_seed_device_s;
        r.batches_s = since(t1);
    };
    if (spec.parallel) {
        // A and B on their devices at once.
        on_both_sides([&](int s) { prepare_side(s), render_side(s); });
    } else {
        // Both sides' devices opened and compiled at once (a driver's start-up, a compiler's
        // run overlap), then A's batches, then B's: each side's speed its own.
        on_both_sides(prepare_side);
        render_side(0), render_side(1);
    }
    for (int s = 0; s < 2; ++s) {
        CompareSideResult& r = sides[s].result;
        const std::string d = sides[s].session->backend().description();
        r.first_device = d;
        r.description = r.devices > 1 ? d + " (+" + std::to_string(r.devices - 1) + " more)" : d;
        r.compile_seconds = sides[s].session->backend().compile_seconds();
        out.sides[s] = std::move(r);
    }
    out.cancelled = cancel_.load();

    // The statistical test (independent seeds) and the same-seed test, on what was rendered.
    const auto tests_start = Clock::now();
    out.has_agreement = out.sides[0].batches_done >= 2 && out.sides[1].batches_done >= 2;
    if (out.has_agreement)
        out.agreement = test_agreement(out.sides[0].batches, out.sides[1].batches, spec.alpha);
    out.has_same_seed = out.sides[0].same_seed_done && out.sides[1].same_seed_done;
    if (out.has_same_seed) {
        out.maps = difference_maps(out.sides[0].same_seed, out.sides[1].same_seed);
        out.same_seed_agrees = out.maps.same_seed.agree(spec.same_seed_limit);
    }
    out.tests_s = since(tests_start);
    out.total_s = since(start);
    return out;
}

}  // namespace mcpt
