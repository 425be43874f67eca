// include/mcpt/mcpt.h section 10 over the engine's CompareJob and ConvergeJob: a job is its
// spec until it runs, then its result; cancel() reaches the job while it runs.
#include <algorithm>
#include <atomic>
#include <cmath>
#include <optional>

#include "common/accel/kdtree.h"
#include "common/analysis/compare_report.h"
#include "common/analysis/converge_report.h"
#include "common/capi/c_api_internal.h"
#include "common/io/html_report.h"
#include "common/render/device_registry.h"

namespace {

using namespace mcpt::capi;

enum class Kind { Compare, Converge };

struct JobBox {
    Kind kind;
    std::mutex mutex;  // serialises calls on the job (cancel does not take it)
    std::shared_ptr<const mcpt::Scene> scene;
    mcpt::CompareSpec compare;
    mcpt::ConvergeSpec converge;
    std::optional<mcpt::CompareResult> compared;
    std::optional<mcpt::ConvergeResult> converged;
    bool released = false;
    // The job while it runs (for cancel()) and the last error, guarded by error_mutex.
    std::mutex error_mutex;
    mcpt::CompareJob* running_compare = nullptr;
    mcpt::ConvergeJob* running_converge = nullptr;
    std::string last_error;
    // Progress of the run under way (mcpt_job_progress), read without the job's lock.
    std::atomic<uint64_t> batches_done{0};  // compare: both sides
    std::atomic<uint64_t> runs_done{0};     // converge
    std::atomic<double> run_fraction{0};    // converge: the run under way
    std::atomic<bool> finished{false};      // the last run ended uncancelled
    std::atomic<double> planned{0};         // batches (compare) or runs (converge) of the run
};

HandleTable<JobBox, mcpt_job>& jobs() {
    static auto* table = new HandleTable<JobBox, mcpt_job>(0x6a6f62000000ull);  // never destroyed
    return *table;
}

mcpt_status job_fail(JobBox& box, mcpt_status status, const std::string& message) {
    std::lock_guard<std::mutex> lock(box.error_mutex);
    box.last_error = message;
    return status;
}

// Looks up the job and runs body(JobBox&) under its lock.
template <class Body>
mcpt_status with_job(mcpt_job j, mcpt_status context, Body&& body) {
    mcpt_status st = MCPT_OK;
    const std::shared_ptr<JobBox> box = lookup(jobs(), j, false, st, "job");
    if (!box) return st;
    std::string message;
    {
        std::lock_guard<std::mutex> lock(box->mutex);
        if (box->released)
            return job_fail(*box, MCPT_ERROR_INVALID_HANDLE, "job is being released");
        st = guarded(context, message, [&] { return body(*box); });
    }
    if (st != MCPT_OK && st != MCPT_CANCELLED) job_fail(*box, st, message);
    return st;
}

mcpt_status create(Kind kind, mcpt_job* out, const std::function<void(JobBox&)>& fill) {
    std::string message;
    const mcpt_status st = guarded(MCPT_ERROR_INVALID_ARGUMENT, message, [&] {
        require(out != nullptr, "out is NULL");
        *out = nullptr;
        auto box = std::make_shared<JobBox>();
        box->kind = kind;
        fill(*box);
        *out = jobs().add(std::move(box));
        return MCPT_OK;
    });
    return st == MCPT_OK ? st : thread_fail(st, message);
}

void require_kind(const JobBox& box, Kind kind) {
    if (box.kind != kind)
        throw CError{MCPT_ERROR_INVALID_ARGUMENT,
                     kind == Kind::Compare ? "not a compare job (mcpt_compare_create)"
                                           : "not a converge job (mcpt_converge_create)"};
}

void set_scene(JobBox& box, mcpt::Scene scene) {
    mcpt::check_lit(scene);
    box.scene = std::make_shared<const mcpt::Scene>(std::move(scene));
}

const mcpt::CompareResult& compared(const JobBox& box) {
    require_kind(box, Kind::Compare);
    if (!box.compared) throw CError{MCPT_ERROR_INVALID_STATE, "the job has not run (mcpt_job_run)"};
    return *box.compared;
}

const mcpt::ConvergeResult& converged(const JobBox& box) {
    require_kind(box, Kind::Converge);
    if (!box.converged)
        throw CError{MCPT_ERROR_INVALID_STATE, "the job has not run (mcpt_job_run)"};
    return *box.converged;
}

const mcpt::ConvergeRun& converge_run(const JobBox& box, uint64_t run) {
    const mcpt::ConvergeResult& r = converged(box);
    require(run < r.runs.size(), "run out of range (mcpt_converge_result.runs)");
    return r.runs[size_t(run)];
}

// Runs the job with `job` reachable by cancel() meanwhile.
template <class Job, class Result>
Result run_reachable(JobBox& box, Job& job, Job*& slot) {
    {
        std::lock_guard<std::mutex> lock(box.error_mutex);
        slot = &job;
    }
    struct Clear {
        JobBox& box;
        Job*& slot;
        ~Clear() {
            std::lock_guard<std::mutex> lock(box.error_mutex);
            slot = nullptr;
        }
    } clear{box, slot};
    return job.run();
}

}  // namespace

extern "C" {

mcpt_status mcpt_compare_create(const char* side_a, const char* side_b, mcpt_job* out) {
    return create(Kind::Compare, out, [&](JobBox& box) {
        require(side_a != nullptr && side_b != nullptr, "a side is NULL");
        const char* sides[2] = {side_a, side_b};
        for (int s = 0; s < 2; ++s) {
            box.compare.sides[s] = mcpt::compare_side(sides[s]);
            for (const std::string& d : box.compare.sides[s].devices) mcpt::parse_device_spec(d);
        }
    });
}

mcpt_status mcpt_converge_create(const char* const* runs, size_t count, mcpt_job* out) {
    return create(Kind::Converge, out, [&](JobBox& box) {
        require(runs != nullptr || count == 0, "runs is NULL");
        require(count >= 1 && count <= 64, "count must be 1 to 64");
        box.converge.runs.clear();
        for (size_t i = 0; i < count; ++i) {
            require(runs[i] != nullptr, "a run is NULL");
            mcpt::ConvergeDevices d;
            d.specs = mcpt::device_list(runs[i]);
            for (const std::string& spec : d.specs) mcpt::parse_device_spec(spec);
            box.converge.runs.push_back(d);
        }
    });
}

mcpt_status mcpt_job_release(mcpt_job j) {
    mcpt_status found = MCPT_OK;
    const std::shared_ptr<JobBox> box = lookup(jobs(), j, true, found, "job");
    if (!box) return found;
    // Stop a run in progress, wait for it, then free everything.
    std::string message;
    const mcpt_status st = guarded(MCPT_ERROR_INTERNAL, message, [&] {
        {
            std::lock_guard<std::mutex> lock(box->error_mutex);
            if (box->running_compare) box->running_compare->cancel();
            if (box->running_converge) box->running_converge->cancel();
        }
        std::lock_guard<std::mutex> lock(box->mutex);
        box->released = true;
        box->compared.reset(), box->converged.reset(), box->scene.reset();
        return MCPT_OK;
    });
    return st == MCPT_OK ? st : thread_fail(st, message);
}

mcpt_status mcpt_job_cancel(mcpt_job j) {
    // No job lock: a run holds it.
    mcpt_status found = MCPT_OK;
    const std::shared_ptr<JobBox> box = lookup(jobs(), j, false, found, "job");
    if (!box) return found;
    try {
        std::lock_guard<std::mutex> lock(box->error_mutex);
        if (box->running_compare) box->running_compare->cancel();
        if (box->running_converge) box->running_converge->cancel();
        return MCPT_OK;
    } catch (...) {
        return thread_fail(MCPT_ERROR_INTERNAL, "internal error in cancel");
    }
}

const char* mcpt_job_last_error(mcpt_job j) {
    return last_error_of(jobs(), j);
}

mcpt_status mcpt_job_load_file(mcpt_job j, const char* path) {
    return with_job(j, MCPT_ERROR_SCENE, [&](JobBox& box) {
        set_scene(box, scene_from_file(path));
        return MCPT_OK;
    });
}

mcpt_status mcpt_job_load_memory(mcpt_job j, const void* data, size_t size, const char* base_dir) {
    return with_job(j, MCPT_ERROR_SCENE, [&](JobBox& box) {
        set_scene(box, scene_from_memory(data, size, base_dir));
        return MCPT_OK;
    });
}

mcpt_status mcpt_job_load_builtin(mcpt_job j, const char* name) {
    return with_job(j, MCPT_ERROR_SCENE, [&](JobBox& box) {
        set_scene(box, scene_builtin(name));
        return MCPT_OK;
    });
}

mcpt_status mcpt_job_set_size(mcpt_job j, int width, int height) {
    return with_job(j, MCPT_ERROR_INVALID_ARGUMENT, [&](JobBox& box) {
        require(width >= 1 && width <= 16384 && height >= 1 && height <= 16384,
                "width and height must be 1 to 16384");
        box.compare.width = box.converge.width = width;
        box.compare.height = box.converge.height = height;
        return MCPT_OK;
    });
}

mcpt_status mcpt_job_set_max_bounces(mcpt_job j, int bounces) {
    return with_job(j, MCPT_ERROR_INVALID_ARGUMENT, [&](JobBox& box) {
        require(bounces >= -1 && bounces <= 1000000, "bounces must be -1 to 1000000");
        box.compare.max_depth = box.converge.max_depth = bounces;
        return MCPT_OK;
    });
}

mcpt_status mcpt_job_set_tree(mcpt_job j, const char* kind) {
    return with_job(j, MCPT_ERROR_INVALID_ARGUMENT, [&](JobBox& box) {
        require(kind != nullptr, "kind is NULL");
        const std::vector<std::string> known = mcpt::tree_kind_names();
        if (std::find(known.begin(), known.end(), kind) == known.end())
            throw CError{MCPT_ERROR_INVALID_ARGUMENT, std::string("unknown tree '") + kind + "'"};
        box.compare.tree = box.converge.tree = kind;
        return MCPT_OK;
    });
}

mcpt_status mcpt_compare_default_options(mcpt_compare_options* out) {
    std::string message;
    const mcpt_status st = guarded(MCPT_ERROR_INVALID_ARGUMENT, message, [&] {
        require(out != nullptr, "out is NULL");
        const mcpt::CompareSpec d;
        *out = mcpt_compare_options{d.batches, d.spp, d.same_seed_spp, d.same_seed_limit, d.alpha,
                                    1.f,       0};
        return MCPT_OK;
    });
    return st == MCPT_OK ? st : thread_fail(st, message);
}

mcpt_status mcpt_compare_set_options(mcpt_job j, const mcpt_compare_options* o) {
    return with_job(j, MCPT_ERROR_INVALID_ARGUMENT, [&](JobBox& box) {
        require_kind(box, Kind::Compare);
        require(o != nullptr, "options is NULL");
        require(o->batches >= 2 && o->batches <= 100000, "batches must be 2 to 100000");
        require(o->spp >= 1 && o->spp <= 1000000, "spp must be 1 to 1000000");
        require(o->same_seed_spp >= 1 && o->same_seed_spp <= 1000000,
                "same_seed_spp must be 1 to 1000000");
        require(o->same_seed_limit >= 0 && o->same_seed_limit <= 1,
                "same_seed_limit must be 0 to 1");
        require(o->alpha >= 1e-12 && o->alpha <= 0.5, "alpha must be 1e-12 to 0.5");
        require(std::isfinite(o->light_scale_b) && o->light_scale_b >= 0,
                "light_scale_b must be finite and >= 0");
        mcpt::CompareSpec& c = box.compare;
        c.batches = o->batches, c.spp = o->spp, c.same_seed_spp = o->same_seed_spp;
        c.same_seed_limit = o->same_seed_limit, c.alpha = o->alpha;
        c.sides[1].light_scale = o->light_scale_b;
        c.parallel = o->parallel != 0;
        return MCPT_OK;
    });
}

mcpt_status mcpt_converge_default_options(mcpt_converge_options* out) {
    std::string message;
    const mcpt_status st = guarded(MCPT_ERROR_INVALID_ARGUMENT, message, [&] {
        require(out != nullptr, "out is NULL");
        const mcpt::ConvergeSpec d;
        *out = mcpt_converge_options{d.seconds, d.max_spp, 0, 0, d.reference_spp, d.seed, 0, 0};
        return MCPT_OK;
    });
    return st == MCPT_OK ? st : thread_fail(st, message);
}

mcpt_status mcpt_converge_set_options(mcpt_job j, const mcpt_converge_options* o) {
    return with_job(j, MCPT_ERROR_INVALID_ARGUMENT, [&](JobBox& box) {
        require_kind(box, Kind::Converge);
        require(o != nullptr, "options is NULL");
        require(std::isfinite(o->seconds) && o->seconds >= 0 && o->seconds <= 1e7,
                "seconds must be 0 to 1e7");
        require(o->seconds > 0 || o->max_spp > 0, "give seconds or max_spp");
        require(o->time_checkpoints == 0 || o->time_checkpoints == 1,
                "time_checkpoints must be 0 or 1");
        require(o->time_checkpoints == 0 || o->seconds > 0, "time checkpoints need seconds");
        require(o->reference >= 0 && o->reference <= 2, "reference must be 0, 1 or 2");
        require(o->reference_spp >= 16 && o->reference_spp <= 100000000,
                "reference_spp must be 16 to 1e8");
        mcpt::ConvergeSpec& c = box.converge;
        c.seconds = o->seconds, c.max_spp = o->max_spp;
        c.schedule =
            o->time_checkpoints ? mcpt::Schedule::TimeDoubling : mcpt::Schedule::SppDoubling;
        static const char* const references[] = {"auto", "exact", "cached"};
        c.reference = references[o->reference];
        c.reference_spp = o->reference_spp, c.seed = o->seed;
        c.samplers = {o->independent ? "independent" : "sobol"};
        c.sampling = {o->adaptive ? "adaptive" : "uniform"};
        return MCPT_OK;
    });
}

mcpt_status mcpt_job_run(mcpt_job j) {
    return with_job(j, MCPT_ERROR_DEVICE, [&](JobBox& box) {
        if (!box.scene)
            throw CError{MCPT_ERROR_INVALID_STATE, "no scene loaded (load one before running)"};
        box.compared.reset(), box.converged.reset();
        box.batches_done = 0, box.runs_done = 0, box.run_fraction = 0, box.finished = false;
        box.planned = box.kind == Kind::Compare ? 2.0 * box.compare.batches
                                                : double(box.converge.runs.size());
        bool cancelled = false;
        if (box.kind == Kind::Compare) {
            mcpt::CompareSpec spec = box.compare;
            spec.scene = box.scene;
            spec.on_batch = [&box](int) { ++box.batches_done; };
            mcpt::CompareJob job(std::move(spec));
            box.compared =
                run_reachable<mcpt::CompareJob, mcpt::CompareResult>(box, job, box.running_compare);
            cancelled = box.compared->cancelled;
        } else {
            mcpt::ConvergeSpec spec = box.converge;
            spec.scene = box.scene;
            spec.label = box.scene->name.empty() ? "scene" : box.scene->name;
            spec.keep_images = true;
            // A run's share: its time against the budget, or its samples against the cap.
            const double seconds = spec.seconds;
            const uint64_t max_spp = spec.max_spp;
            spec.on_checkpoint = [&box, seconds, max_spp](const mcpt::ConvergeRun&,
                                                          const mcpt::Checkpoint& c) {
                double f = seconds > 0 ? c.seconds / seconds : 0;
                if (max_spp > 0) f = std::max(f, double(c.spp) / double(max_spp));
                box.run_fraction = std::min(1.0, f);
            };
            spec.on_run_end = [&box](const mcpt::ConvergeRun&, const mcpt::Session&) {
                ++box.runs_done;
                box.run_fraction = 0;
            };
            mcpt::ConvergeJob job(std::move(spec));
            box.converged = run_reachable<mcpt::ConvergeJob, mcpt::ConvergeResult>(
                box, job, box.running_converge);
            cancelled = box.converged->cancelled;
        }
        box.finished = !cancelled;
        return cancelled ? MCPT_CANCELLED : MCPT_OK;
    });
}

mcpt_status mcpt_job_progress(mcpt_job j, double* fraction) {
    // No job lock: a run holds it.
    mcpt_status found = MCPT_OK;
    const std::shared_ptr<JobBox> box = lookup(jobs(), j, false, found, "job");
    if (!box) return found;
    if (!fraction) return job_fail(*box, MCPT_ERROR_INVALID_ARGUMENT, "fraction is NULL");
    double f = 1;
    const double planned = box->planned;
    if (!box->finished) {
        const double done = box->kind == Kind::Compare ? double(box->batches_done)
                                                       : double(box->runs_done) + box->run_fraction;
        f = planned > 0 ? done / planned : 0;
    }
    *fraction = std::min(1.0, std::max(0.0, f));
    return MCPT_OK;
}

mcpt_status mcpt_job_write_report(mcpt_job j, const char* dir) {
    return with_job(j, MCPT_ERROR_IO, [&](JobBox& box) {
        require(dir != nullptr && *dir, "dir is NULL or empty");
        if (box.kind == Kind::Compare) {
            const mcpt::CompareResult& r = compared(box);
            mcpt::prepare_report_dir(dir);
            mcpt::write_compare_report(r, box.scene->name.empty() ? "scene" : box.scene->name, dir);
        } else {
            const mcpt::ConvergeResult& r = converged(box);
            mcpt::prepare_report_dir(dir);
            mcpt::write_converge_report(r, dir);
        }
        return MCPT_OK;
    });
}

mcpt_status mcpt_compare_get_result(mcpt_job j, mcpt_compare_result* out) {
    return with_job(j, MCPT_ERROR_INTERNAL, [&](JobBox& box) {
        require(out != nullptr, "out is NULL");
        const mcpt::CompareResult& r = compared(box);
        mcpt_compare_result o;
        std::memset(&o, 0, sizeof o);
        o.agree = r.agree(), o.cancelled = r.cancelled;
        o.statistical_tested = r.has_agreement;
        const mcpt::Agreement& a = r.agreement;
        o.statistical_agree = r.has_agreement && a.agree;
        o.pixels_tested = a.pixels_tested, o.min_p = a.min_p, o.sidak_level = a.sidak_level;
        o.sidak_rejections = a.sidak_rejections, o.bh_discoveries = a.bh_discoveries;
        o.mean_z_score = a.mean_z_score, o.chi2_score = a.chi2_score;
        o.global_z_limit = a.global_z_limit, o.detectable_bias = a.detectable_bias;
        o.mean_relative_diff = a.mean_relative_diff;
        o.same_seed_tested = r.has_same_seed, o.same_seed_agree = r.same_seed_agrees;
        o.same_seed_pixels = r.maps.same_seed.pixels;
        o.same_seed_diverged = r.maps.same_seed.diverged;
        o.same_seed_max_abs_diff = r.maps.same_seed.max_abs_diff;
        o.speed_ratio = r.speed_ratio(), o.seconds = r.total_s;
        for (int s = 0; s < 2; ++s) {
            const mcpt::CompareSideResult& side = r.sides[s];
            mcpt_compare_side& os = o.side[s];
            copy(os.device, sizeof os.device, side.description);
            copy(os.tree, sizeof os.tree, side.tree);
            os.devices = int(side.devices), os.batches_done = side.batches_done;
            os.nonfinite = side.batches.nonfinite;
            os.samples_per_second = side.samples_per_second();
            os.rays_per_second = side.rays_per_second();
            os.device_ns_per_sample = side.device_ns_per_sample();
            os.compile_seconds = side.compile_seconds;
        }
        *out = o;
        return MCPT_OK;
    });
}

mcpt_status mcpt_compare_read_map(mcpt_job j, mcpt_compare_map map, float* rgba, size_t capacity) {
    int which = 0;
    std::memcpy(&which, &map, sizeof which);  // any int a C caller passes
    return with_job(j, MCPT_ERROR_INTERNAL, [&](JobBox& box) {
        const mcpt::CompareResult& r = compared(box);
        require(which >= 0 && which <= 3, "unknown map");
        require(rgba != nullptr, "rgba is NULL");
        const size_t pixels = size_t(r.width) * size_t(r.height);
        require(capacity >= 4 * pixels, "capacity < 4 * width * height");
        const std::vector<float> test = mcpt::compare_test_map(r);
        for (size_t i = 0; i < pixels; ++i) {
            float v = 0;
            if (which <= 2)
                v = test[3 * i + size_t(which)];
            else if (r.has_same_seed)
                v = r.maps.relative[i];
            rgba[4 * i] = rgba[4 * i + 1] = rgba[4 * i + 2] = v;
            rgba[4 * i + 3] = 1.f;
        }
        return MCPT_OK;
    });
}

mcpt_status mcpt_converge_get_result(mcpt_job j, mcpt_converge_result* out) {
    return with_job(j, MCPT_ERROR_INTERNAL, [&](JobBox& box) {
        require(out != nullptr, "out is NULL");
        const mcpt::ConvergeResult& r = converged(box);
        *out = mcpt_converge_result{uint64_t(r.runs.size()), r.biased(), r.cancelled,
                                    r.reference.mean_value(), r.reference.exact()};
        return MCPT_OK;
    });
}

mcpt_status mcpt_converge_get_run(mcpt_job j, uint64_t run, mcpt_converge_run* out) {
    return with_job(j, MCPT_ERROR_INTERNAL, [&](JobBox& box) {
        require(out != nullptr, "out is NULL");
        const mcpt::ConvergeRun& r = converge_run(box, run);
        mcpt_converge_run o;
        std::memset(&o, 0, sizeof o);
        copy(o.backend, sizeof o.backend, r.backend);
        copy(o.device, sizeof o.device, r.device);
        o.checkpoints = r.checkpoints.size();
        o.time_slope = r.report.time_fit.slope, o.spp_slope = r.report.spp_fit.slope;
        o.slope_sigma = r.report.slope_sigma, o.local_slope = r.report.local_slope;
        o.biased = r.report.biased, o.relative_bias = r.report.relative_bias;
        *out = o;
        return MCPT_OK;
    });
}

mcpt_status mcpt_converge_get_checkpoint(mcpt_job j, uint64_t run, uint64_t index,
                                         mcpt_checkpoint* out) {
    return with_job(j, MCPT_ERROR_INTERNAL, [&](JobBox& box) {
        require(out != nullptr, "out is NULL");
        const mcpt::ConvergeRun& r = converge_run(box, run);
        require(index < r.checkpoints.size(), "checkpoint out of range");
        const mcpt::Checkpoint& c = r.checkpoints[size_t(index)];
        *out = mcpt_checkpoint{c.seconds,
                               c.spp,
                               c.error.rmse,
                               c.error.rel_rmse,
                               c.error.rel_mse,
                               c.error.mean_signed_error,
                               c.error.reference_noise};
        return MCPT_OK;
    });
}

mcpt_status mcpt_converge_time_to_error(mcpt_job j, uint64_t run, double target, double* seconds,
                                        int* how) {
    return with_job(j, MCPT_ERROR_INTERNAL, [&](JobBox& box) {
        require(seconds != nullptr && how != nullptr, "seconds or how is NULL");
        require(std::isfinite(target) && target > 0, "target must be positive");
        const mcpt::ConvergeRun& r = converge_run(box, run);
        const mcpt::TimeToError t = mcpt::time_to_error(r.checkpoints, target, r.report);
        *seconds = t.seconds;
        *how = t.before_first ? 3 : t.reached ? 1 : t.extrapolated ? 2 : 0;
        return MCPT_OK;
    });
}

}  // extern "C"
