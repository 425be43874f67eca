#include "common/analysis/converge_job.h"

#include <cstdio>

#include "common/accel/kdtree.h"
#include "common/error.h"
#include "common/render/device_registry.h"
#include "common/render/prepare.h"
#include "common/scene/scene_load.h"

namespace mcpt {

std::vector<ConvergeDevices> converge_devices(const std::vector<std::string>& backends,
                                              const std::vector<std::string>& devices,
                                              bool beside_one) {
    std::vector<ConvergeDevices> runs;
    for (const std::string& backend : backends) {
        const std::vector<std::string> specs = device_specs(backend, devices);
        if (beside_one && specs.size() > 1) runs.push_back({{specs.front()}, false, true});
        runs.push_back({specs, false, false});
    }
    return runs;
}

bool ConvergeResult::biased() const {
    for (const ConvergeRun& r : runs)
        if (r.report.biased) return true;
    return false;
}

ConvergeJob::ConvergeJob(ConvergeSpec spec) : spec_(std::move(spec)) {
    const ConvergeSpec& s = spec_;
    if (!s.scene) throw Error("converge: no scene");
    if (s.runs.empty()) throw Error("converge: no device to render on");
    for (const ConvergeDevices& d : s.runs)
        if (d.specs.empty()) throw Error("converge: a run without a device");
    if (s.width < 1 || s.height < 1) throw Error("converge: an empty image");
    if (!(s.seconds > 0) && s.max_spp == 0)
        throw Error("converge: give a time budget or a sample count");
    if (s.schedule == Schedule::TimeDoubling && !(s.seconds > 0))
        throw Error("converge: time checkpoints need a time budget");
    if (s.samplers.empty() || s.sampling.empty())
        throw Error("converge: give a sampler and a sampling");
    for (const std::string& sampler : s.samplers)
        if (sampler != "sobol" && sampler != "independent")
            throw Error("converge: unknown sampler '" + sampler + "' (sobol, independent)");
    for (const std::string& sampling : s.sampling)
        if (sampling != "uniform" && sampling != "adaptive")
            throw Error("converge: unknown sampling '" + sampling + "' (uniform, adaptive)");
    if (s.reference != "auto" && s.reference != "exact" && s.reference != "cached")
        throw Error("converge: unknown reference '" + s.reference + "' (auto, exact, cached)");
    for (double t : s.targets)
        if (!(t > 0)) throw Error("converge: target errors must be positive");
}

void ConvergeJob::cancel() {
    cancel_.store(true);
    std::lock_guard<std::mutex> lock(running_mutex_);
    if (running_) running_->cancel();  // ends the step under way
}

// A session for one device list: the scene and the settings every run of it shares.
std::unique_ptr<Session> ConvergeJob::open_session(const ConvergeDevices& devices) const {
    auto session = std::make_unique<Session>(devices.specs, BackendOptions{});
    session->set_scene(*spec_.scene);
    session->settings().width = spec_.width, session->settings().height = spec_.height;
    session->settings().max_depth =
        spec_.max_depth >= 0 ? spec_.max_depth : default_max_depth(*spec_.scene);
    session->settings().tree = spec_.tree;  // auto: the tree this device's cost model picks
    return session;
}

// The exact solution, or a high-sample render cached per scene content, size and bounces.
Reference ConvergeJob::make_reference(const GpuScene& g, uint32_t max_depth) {
    const ConvergeSpec& s = spec_;
    double exact = 0;
    const bool has_exact = exact_furnace_radiance(*s.scene, exact);
    if (s.reference == "exact" && !has_exact)
        throw Error("no exact solution is known for '" + s.label + "' (use --reference cached)");
    if (s.reference != "cached" && has_exact) {
        char src[96];
        std::snprintf(src, sizeof src, "exact: Le/(1-rho) = %g everywhere", exact);
        return constant_reference(s.width, s.height, exact, src);
    }
    // Cached: the key covers the rendered content and the kernel source, never the tree.
    RenderOptions ro;
    ro.width = s.width, ro.height = s.height, ro.max_depth = max_depth;
    const uint64_t key = reference_key(g, s.scene->camera, s.width, s.height, ro.max_depth,
                                       ro.rr_depth, device_source_key());
    char name[160];
    std::snprintf(name, sizeof name, "%s-%dx%d-d%u-%016llx.ref", s.label.c_str(), s.width, s.height,
                  ro.max_depth, (unsigned long long)key);
    const std::string path = reference_cache_dir() + "/" + name;
    Reference ref;
    if (load_reference(path, s.width, s.height, ref)) return ref;
    // Not cached yet: render it once on the first device, with seeds no checkpoint uses.
    const std::string device = s.reference_device.empty() ? s.runs[0].specs[0] : s.reference_device;
    if (s.on_reference)
        s.on_reference("rendering the reference (" + std::to_string(s.reference_spp) + " spp on " +
                       device + ") into " + path + " ...");
    std::unique_ptr<Backend> backend = open_device(device);
    ro.spp = s.reference_spp;
    ro.seed = 0x7e000000u;
    // Independent samples: their sample variance is the reference's own error, which every
    // MSE subtracts (a low-discrepancy sampler's would overstate it).
    GpuScene independent = g;
    independent.features |= FEATURE_INDEPENDENT_SAMPLER;
    ProgressFn progress;
    if (s.reference_progress)
        progress = [&](double f, const RenderResult& so_far) {
            s.reference_progress(f, so_far.seconds);
        };
    const RenderResult rr = render(*backend, independent, s.scene->camera, ro, progress);
    ref = reference_from_render(rr, "rendered " + path + " (" + std::to_string(rr.spp) + " spp)");
    save_reference(path, ref);
    return ref;
}

// The seed of run `index` (the runs of every device list counted in order, a `beside` run's
// as its twin's).
static uint32_t run_seed(const ConvergeSpec& s, size_t index) {
    return s.seed + 100000u * uint32_t(index);
}

// Each device list's first run among all runs, for run_seed().
static std::vector<size_t> first_runs(const ConvergeSpec& s) {
    std::vector<size_t> first;
    size_t runs = 0;
    for (const ConvergeDevices& d : s.runs) {
        first.push_back(runs);
        if (!d.beside) runs += s.samplers.size() * s.sampling.size();
    }
    return first;
}

void ConvergeJob::serve(const std::function<void(Session&)>& serve) {
    const std::vector<size_t> first = first_runs(spec_);
    for (size_t j = 0; j < spec_.runs.size(); ++j) {
        if (!spec_.runs[j].with_ranks) continue;
        size_t index = first[j];
        std::unique_ptr<Session> session = open_session(spec_.runs[j]);
        for (const std::string& sampler : spec_.samplers)
            for (const std::string& sampling : spec_.sampling) {
                session->settings().sampler = sampler;
                session->settings().adaptive = sampling == "adaptive";
                session->settings().seed = run_seed(spec_, index++);
                serve(*session);
            }
    }
}

ConvergeResult ConvergeJob::run() {
    const ConvergeSpec& s = spec_;
    ConvergeResult out;
    out.label = s.label;
    out.width = s.width, out.height = s.height;
    out.targets = s.targets;
    out.max_depth = uint32_t(s.max_depth >= 0 ? s.max_depth : default_max_depth(*s.scene));
    // Reference.
    const GpuScene g = pack_scene(*s.scene, build_kdtree(s.scene->triangles, tree_options(s.tree)));
    out.reference = make_reference(g, out.max_depth);
    char settings[256];
    std::snprintf(settings, sizeof settings,
                  "scene %s, %dx%d, max depth %u, %s checkpoints, budget %g s%s per backend",
                  s.label.c_str(), s.width, s.height, out.max_depth,
                  s.schedule == Schedule::TimeDoubling ? "time" : "geometric", s.seconds,
                  s.max_spp ? (" or " + std::to_string(s.max_spp) + " spp").c_str() : "");
    out.settings = settings;
    if (s.on_ready) s.on_ready(out);

    // Progressive renders, one device list after the other.
    const std::vector<size_t> first = first_runs(s);
    for (size_t j = 0; j < s.runs.size() && !cancel_.load(); ++j) {
        const ConvergeDevices& devices = s.runs[j];
        std::unique_ptr<Session> session = open_session(devices);
        {
            std::lock_guard<std::mutex> lock(running_mutex_);
            running_ = session.get();
        }
        struct Clear {  // the session ends with this scope: cancel() no longer reaches it
            ConvergeJob* job;
            ~Clear() {
                std::lock_guard<std::mutex> lock(job->running_mutex_);
                job->running_ = nullptr;
            }
        } clear{this};
        size_t index = first[j];
        for (const std::string& sampler : s.samplers)
            for (const std::string& sampling : s.sampling) {
                if (cancel_.load()) break;
                session->settings().sampler = sampler;
                session->settings().adaptive = sampling == "adaptive";
                session->settings().seed = run_seed(s, index++);
                // Under mpirun: the other ranks join this run (each said it has the same job).
                if (devices.with_ranks && s.remote)
                    for (auto& w : s.remote(*session)) session->add_worker(std::move(w));
                ConvergeRun run;
                run.devices = session->device_count();
                run.backend = session->device().backend;
                if (run.devices > 1)
                    run.backend +=
                        " x" + std::to_string(run.devices) + (devices.with_ranks ? " ranks" : "");
                if (s.samplers.size() > 1) run.backend += "/" + sampler;
                if (s.sampling.size() > 1) run.backend += "/" + sampling;
                run.device = session->device().name;
                if (devices.specs.size() > 1)
                    for (size_t d = 1; d < session->device_names().size(); ++d)
                        run.device += " + " + session->device_names()[d];
                ProgressiveOptions po;
                po.schedule = s.schedule;
                po.seconds = s.seconds, po.max_spp = s.max_spp;
                po.seed_base = session->settings().seed;
                po.cancel = &cancel_;
                RenderResult total;
                run.checkpoints = render_progressive(*session, po, out.reference, &total,
                                                     [&](const Checkpoint& c) {
                                                         if (s.on_checkpoint)
                                                             s.on_checkpoint(run, c);
                                                     });
                if (s.on_run_end) s.on_run_end(run, *session);
                // The ranks' part of this run ends (each goes on to the next).
                session->remove_workers();
                if (run.checkpoints.empty()) continue;  // cancelled before its first
                run.report = analyze_convergence(run.checkpoints, out.reference.mean_value(),
                                                 effective_pixels(total));
                for (double target : s.targets)
                    run.time_to_target.push_back(
                        time_to_error(run.checkpoints, target, run.report));
                if (s.keep_images) run.image = total.mean_image();
                out.runs.push_back(std::move(run));
            }
    }
    out.cancelled = cancel_.load();
    return out;
}

}  // namespace mcpt
