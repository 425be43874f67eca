#include "common/render/session.h"

#include <mcpt/mcpt.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <thread>

#include "common/error.h"
#include "common/io/image_io.h"
#include "common/render/checkpoint.h"
#include "common/render/device_registry.h"
#include "common/render/prepare.h"
#include "common/scene/scene_load.h"

namespace mcpt {

namespace {
std::string join(const std::vector<std::string>& names) {
    std::string out;
    for (const std::string& n : names) out += (out.empty() ? "" : ", ") + n;
    return out;
}

// Everything a checkpoint must match to continue this session's image.
Fingerprint fingerprint_of(const Session& session) {
    const SessionSettings& s = session.settings();
    char hash[32];
    std::snprintf(hash, sizeof hash, "%016llx", (unsigned long long)scene_hash(session.scene()));
    char scale[32];
    std::snprintf(scale, sizeof scale, "%.9g", double(s.light_scale));
    return {
        {"mcpt", MCPT_VERSION_STRING},
        {"scene", session.scene().name + " " + hash},
        {"width", std::to_string(s.width)},
        {"height", std::to_string(s.height)},
        {"max_depth", std::to_string(session.max_depth())},
        {"seed", std::to_string(s.seed)},
        {"tree", s.tree + " " + std::to_string(s.tree_depth)},
        {"specialize", s.specialize ? "on" : "off"},
        {"sampler", s.sampler},
        {"reproducible", s.reproducible ? "on" : "off"},
        {"adaptive", s.adaptive ? "on" : "off"},
        {"light_scale", scale},
        {"device", join(session.device_names())},
        {"samples", session.part().job_spp == 0 ? std::string("all")
                                                : std::to_string(session.part().first) + "-" +
                                                      std::to_string(session.part().end) + " of " +
                                                      std::to_string(session.part().job_spp)}};
}

// A device of this process as a worker of a job on several (coordinator.h).
class SessionWorker : public Worker {
  public:
    explicit SessionWorker(Session& s) : s_(s) {}
    std::string name() const override { return s_.device().label(); }
    void render(const Chunk& chunk) override { s_.render_chunk(chunk.first, chunk.end); }
    void finish_round() override { s_.finish_round(); }
    void add_round_to(RenderResult& total) override { s_.add_round_to(total); }
    const RenderResult* round_sums() override { return s_.round_sums(); }
    void start_round() override { s_.start_round(); }

  private:
    Session& s_;
};

bool same(const SessionSettings& a, const SessionSettings& b) {
    return a.width == b.width && a.height == b.height && a.max_depth == b.max_depth &&
           a.tree == b.tree && a.tree_depth == b.tree_depth && a.seed == b.seed &&
           a.specialize == b.specialize && a.sampler == b.sampler &&
           a.reproducible == b.reproducible && a.adaptive == b.adaptive &&
           a.dispatch_ms == b.dispatch_ms && a.light_scale == b.light_scale;
}
// All but the seed and the light scale, which a render loop can restart with.
bool same_but_seed_and_light_scale(SessionSettings a, const SessionSettings& b) {
    a.seed = b.seed, a.light_scale = b.light_scale;
    return same(a, b);
}
// The settings the device's program and buffers depend on (the rest: seed, light scale,
// timings, only the render loop's).
bool same_on_device(const SessionSettings& a, const SessionSettings& b) {
    return a.width == b.width && a.height == b.height && a.max_depth == b.max_depth &&
           a.tree == b.tree && a.tree_depth == b.tree_depth && a.specialize == b.specialize &&
           a.sampler == b.sampler && a.reproducible == b.reproducible;
}
}  // namespace

Session::Session(const std::string& device_spec, BackendOptions options) {
    // Specialization is a session setting: the backend compiles what commit() asks for.
    options.features = 0;
    backend_ = open_device(device_spec, options);
}

Session::Session(const std::vector<std::string>& device_specs, BackendOptions options) {
    if (device_specs.empty()) throw Error("no device given");
    options.features = 0;
    backend_ = open_device(device_specs[0], options);
    for (size_t i = 1; i < device_specs.size(); ++i)
        helpers_.push_back(std::make_unique<Session>(device_specs[i], options));
}

void Session::add_worker(std::unique_ptr<Worker> worker) {
    if (!worker) throw Error("no worker given");
    remote_.push_back(std::move(worker));
    dirty_ = true;
}

void Session::remove_workers() {
    if (remote_.empty()) return;
    remote_.clear();
    rates_.clear();
    dirty_ = true;
}

std::vector<std::string> Session::device_names() const {
    // Distinct names, in order: what the image depends on in reproducible mode.
    std::vector<std::string> names{device().label()};
    auto add = [&](const std::string& n) {
        for (const std::string& m : names)
            if (m == n) return;
        names.push_back(n);
    };
    for (const auto& h : helpers_) add(h->device().label());
    for (const auto& w : remote_) add(w->device_name());
    return names;
}

Session::Session(std::unique_ptr<Backend> backend) : backend_(std::move(backend)) {
    if (!backend_) throw Error("a session needs a device");
}

Session::~Session() = default;

void Session::set_scene(Scene scene) {
    scene_ = std::move(scene);
    if (environment_.present()) scene_.environment = environment_;
    keep_light_choice_possible();
    has_scene_ = true;
    dirty_ = true;
    loaded_ = false;
}

void Session::set_environment(Environment env) {
    environment_ = std::move(env);
    scene_.environment = environment_;
    keep_light_choice_possible();
    dirty_ = true;
    loaded_ = false;
}

void Session::keep_light_choice_possible() {
    // Lamps by contribution need lamps alone: with an environment added (the C API sets it
    // after the scene), auto's next choice.
    if (scene_.light_by_contribution && !scene_.lamp_choice_possible())
        scene_.choose_lights_automatically();
}

int Session::max_depth() const {
    return settings_.max_depth >= 0 ? settings_.max_depth : default_max_depth(scene_);
}

void Session::commit() {
    if (!has_scene_) throw Error("no scene loaded");
    const SessionSettings& s = settings_;
    if (s.width <= 0 || s.height <= 0 || s.width > 16384 || s.height > 16384)
        throw Error("image size must be between 1x1 and 16384x16384");
    if (!(s.dispatch_ms >= 0) || !(s.light_scale >= 0))
        throw Error("dispatch time must be 0 (the device's) or positive, light scale 0 or more");
    if (s.sampler != "sobol" && s.sampler != "independent")
        throw Error("unknown sampler '" + s.sampler + "' (sobol or independent)");
    if (s.adaptive && s.reproducible)
        throw Error(
            "adaptive sampling is not reproducible (its sample counts follow the noise): "
            "turn one of them off");
    // Only the seed or the light scale changed (compare's batches, converge's runs): the loop
    // starts over from empty sums, the scene kept on the device and the loop's measured
    // timings kept (a new loop starts from small dispatches: ~25 ms a 1024x1024 batch on an
    // H200).
    if (!dirty_ && progressive_ && !several() && !s.adaptive && lost_.empty() &&
        same_but_seed_and_light_scale(s, committed_settings_)) {
        progressive_->restart(s.seed, s.light_scale, part_.first);
        round_open_ = round_flushed_ = false;
        committed_settings_ = s;
        return;
    }
    progressive_.reset();
    dirty_ = true;
    // Tree, layout, limits; then compile and upload (unless only the seed, the light scale
    // or the timings changed: the scene stays on the device).
    if (!loaded_ || !same_on_device(s, loaded_settings_)) {
        loaded_ = false;
        prepared_ =
            prepare_scene(scene_, device(), tree_options(s.tree, s.tree_depth), s.width, s.height);
        GpuScene to_load = prepared_;
        if (!s.specialize) to_load.features = FEATURE_ALL;
        if (s.sampler == "independent") to_load.features |= FEATURE_INDEPENDENT_SAMPLER;
        backend_->load(to_load, s.width, s.height, s.reproducible);
        loaded_ = true;
        loaded_settings_ = s;
    }
    RenderOptions ro;
    ro.width = s.width, ro.height = s.height;
    ro.max_depth = uint32_t(max_depth());
    ro.seed = s.seed;
    ro.light_scale = s.light_scale;
    ro.dispatch_ms = s.dispatch_ms;
    if (s.reproducible) ro.group_spp = kReproducibleGroupSpp;
    ro.adaptive = s.adaptive;
    progressive_ = std::make_unique<ProgressiveRender>(*backend_, prepared_, scene_.camera, ro);
    // The other devices of this process, with the same scene and settings, prepared and
    // compiled at once.
    std::vector<Session*> helpers;
    for (auto& h : helpers_) {
        h->set_scene(scene_);
        h->settings() = s;
        helpers.push_back(h.get());
    }
    commit_all(helpers, 1);
    total_ = RenderResult{};
    total_.width = s.width, total_.height = s.height;
    if (several()) {
        // The image's sums, allocated (and touched) now, not in the first round.
        const size_t n = size_t(s.width) * size_t(s.height);
        total_.sum.assign(3 * n, 0.0), total_.sum_sq.assign(3 * n, 0.0);
        total_.nonfinite.assign(n, 0.0);
        if (s.reproducible) total_.exact.assign(6 * n, 0);
    }
    total_.first = part_.first;
    device_stats_.clear();
    rounds_ = 0, collect_total_s_ = 0;
    round_open_ = round_flushed_ = false;
    if (part_.first > 0) progressive_->begin_at(part_.first);
    committed_settings_ = s;
    dirty_ = false;
}

void Session::render_chunk(uint64_t first, uint64_t end) {
    if (!lost_.empty()) throw DeviceLost("the device stopped earlier (" + lost_ + ")");
    if (end <= first) throw Error("an empty sample range");
    if (dirty_ || !same(settings_, committed_settings_)) commit();
    ProgressiveRender& pr = *progressive_;
    if (round_open_)
        pr.continue_at(first);
    else
        pr.begin_at(first);
    round_open_ = true, round_flushed_ = false;
    RenderResult& r = pr.result();
    const uint64_t before = r.spp, n = end - first;
    try {
        while (r.spp - before < n) pr.pass(n - (r.spp - before));
    } catch (const DeviceLost& e) {
        lost_ = e.what();
        throw;
    }
}

void Session::finish_round() {
    if (!round_open_ || round_flushed_) return;
    try {
        progressive_->flush();
    } catch (const DeviceLost& e) {
        lost_ = e.what();
        throw;
    }
    round_flushed_ = true;
}

void Session::add_round_to(RenderResult& total) {
    if (const RenderResult* sums = round_sums()) {
        accumulate_sums(total, *sums);
        start_round();
    }
}

const RenderResult* Session::round_sums() {
    if (!round_open_) return nullptr;
    finish_round();
    return &progressive_->settled_sums();
}

void Session::start_round() {
    round_open_ = round_flushed_ = false;
}

double Session::round_seconds() const {
    return std::max({1.0, 4 * committed_settings_.chunk_seconds, 25 * reduce_seconds_});
}

double Session::step_seconds() const {
    return several() ? round_seconds() : 25 * collect_s_;
}

void Session::add_stats(const std::vector<WorkerStats>& job) {
    if (device_stats_.size() != job.size()) device_stats_.assign(job.size(), WorkerStats{});
    for (size_t w = 0; w < job.size(); ++w) {
        WorkerStats& d = device_stats_[w];
        d.name = job[w].name;
        d.chunks += job[w].chunks, d.samples += job[w].samples, d.seconds += job[w].seconds;
        d.finish_seconds += job[w].finish_seconds;
        d.rate = job[w].rate;
    }
}

PassStats Session::render_on_devices(double budget_s, double target_error, uint64_t max_spp) {
    using clock = std::chrono::steady_clock;
    const SessionSettings& s = committed_settings_;
    if (s.adaptive)
        throw Error("adaptive sampling runs on one device: its plan needs the whole image's noise");
    if (s.reproducible &&
        (max_spp % kReproducibleGroupSpp != 0 || part_.first % kReproducibleGroupSpp != 0))
        throw Error("a reproducible render on several devices takes a multiple of " +
                    std::to_string(kReproducibleGroupSpp) + " samples per pixel, not " +
                    std::to_string(max_spp));
    const auto start = clock::now();
    auto elapsed = [&] { return std::chrono::duration<double>(clock::now() - start).count(); };
    const uint64_t spp_before = total_.spp;
    const double seconds_before = total_.seconds;
    // This device, the others of this process, then those elsewhere.
    std::vector<std::unique_ptr<Worker>> local;
    std::vector<Worker*> workers;
    local.push_back(std::make_unique<SessionWorker>(*this));
    for (auto& h : helpers_) local.push_back(std::make_unique<SessionWorker>(*h));
    for (auto& w : local) workers.push_back(w.get());
    for (auto& w : remote_) workers.push_back(w.get());
    // Rounds of a few chunks each: the image, the error and a cancel are looked at between.
    PassStats st;
    while (true) {
        JobLimits lim;
        lim.end = max_spp > 0 ? total_.first + max_spp : 0;
        lim.seconds = std::clamp(budget_s - elapsed(), 1e-9, round_seconds());
        // With a target error: a first round of a second, then rounds that end where the
        // error, falling as 1 / sqrt(samples), is expected to reach it.
        if (target_error > 0 && total_.spp < 2) lim.seconds = std::min(lim.seconds, 1.0);
        if (target_error > 0 && total_.spp >= 2) {
            const double ratio = std::min(total_.relative_error() / target_error, 1e3);
            const uint64_t g = s.reproducible ? kReproducibleGroupSpp : 1;
            const uint64_t needed = std::max<uint64_t>(
                uint64_t(std::ceil(double(total_.spp) * ratio * ratio * 1.02 / g)) * g,
                total_.spp + g);
            const uint64_t end = total_.first + needed;
            lim.end = lim.end > 0 ? std::min(lim.end, end) : end;
        }
        lim.granule = s.reproducible ? kReproducibleGroupSpp : 1;
        lim.chunk_seconds = s.chunk_seconds;
        // A device joins a round for no less than the last round's collection took.
        lim.min_share_seconds = reduce_seconds_;
        Coordinator round(total_, lim, workers, rates_);
        try {
            round.run(&cancel_);
        } catch (const DeviceLost& e) {
            lost_ = e.what();
            total_.seconds = seconds_before + elapsed();
            add_stats(round.stats());
            throw;
        } catch (...) {
            // The round adds nothing: its samples are dropped on every device.
            round_open_ = round_flushed_ = false;
            for (auto& h : helpers_) h->round_open_ = h->round_flushed_ = false;
            total_.seconds = seconds_before + elapsed();
            add_stats(round.stats());
            throw;
        }
        rates_ = round.rates();
        add_stats(round.stats());
        // Collecting the sums stops every device: rounds last 25 times longer (4% at most).
        reduce_seconds_ = round.reduce_seconds();
        collect_total_s_ += reduce_seconds_;
        ++rounds_;
        if (round.cancelled()) {
            st.cancelled = true;
            break;
        }
        if (max_spp > 0 && total_.spp >= max_spp) break;
        if (target_error > 0 && total_.spp >= 2 && total_.relative_error() <= target_error) break;
        // The budget is spent, or too little of it is left for a chunk.
        if (elapsed() >= budget_s || (round.out_of_time() && lim.seconds < round_seconds())) break;
    }
    st.samples = total_.spp - spp_before;
    st.spp = total_.spp;
    st.relative_error = total_.relative_error();
    st.target_reached = target_error > 0 && st.relative_error <= target_error;
    st.seconds = elapsed();
    total_.seconds = seconds_before + st.seconds;
    cancel_.store(false);
    return st;
}

PassStats Session::render(double budget_ms, double target_error, uint64_t max_spp) {
    using clock = std::chrono::steady_clock;
    if (!(budget_ms >= 0) || !std::isfinite(budget_ms))
        throw Error("the time budget must be a finite number of milliseconds >= 0");
    if (!(target_error >= 0) || !std::isfinite(target_error))
        throw Error("the target error must be finite and >= 0");
    if (!lost_.empty())
        throw DeviceLost("the device stopped earlier (" + lost_ +
                         "); open a new session to render more");
    // A cancel() from now on, during the commit too, ends this render.
    cancel_.store(false);
    if (dirty_ || !same(settings_, committed_settings_)) commit();
    if (several()) return render_on_devices(budget_ms * 1e-3, target_error, max_spp);
    const auto start = clock::now();
    auto elapsed = [&] { return std::chrono::duration<double>(clock::now() - start).count(); };
    RenderResult& r = progressive_->result();
    PassStats st;
    const uint64_t spp_before = r.spp;
    const double budget_s = budget_ms * 1e-3;
    double checked_at = -1;
    try {
        while (true) {
            if (max_spp > 0 && r.spp >= max_spp) break;
            progressive_->pass(max_spp > 0 ? max_spp - r.spp : UINT64_MAX);
            // Samples to the host at least once a second (a lost device loses no more), and
            // the error looked at every 0.1 s with a target; both at most every ten times
            // what they cost (a read-back and a pass over the image: large images).
            const double t = elapsed();
            const bool check = target_error > 0 && t - checked_at >= std::max(0.1, 10 * collect_s_);
            if (check || progressive_->seconds_since_flush() > std::max(1.0, 10 * collect_s_)) {
                const double c0 = elapsed();
                progressive_->flush();
                const bool reached = check && r.spp >= 2 && r.relative_error() <= target_error;
                collect_s_ = elapsed() - c0;
                readbacks_ += 1, readback_total_s_ += collect_s_;
                if (check) checked_at = t;
                if (reached) break;
            }
            // Cancelled: after at least one pass, as the budget.
            if (cancel_.load()) {
                st.cancelled = true;
                break;
            }
            // Stop when the next pass would overrun the budget.
            if (t + progressive_->last_pass_seconds() > budget_s) break;
        }
        const double c0 = elapsed();
        progressive_->flush();
        st.relative_error = r.relative_error();
        collect_s_ = elapsed() - c0;
        readbacks_ += 1, readback_total_s_ += collect_s_;
    } catch (const DeviceLost& e) {
        // The device's sums are gone: keep what was read back, render no more.
        progressive_->discard_unflushed();
        r.seconds += elapsed();
        lost_ = e.what();
        throw;
    } catch (...) {
        // Another failure (out of memory, a driver error): keep what was read back; the next
        // render() starts a new round over it (the device sums are overwritten, not added).
        progressive_->discard_unflushed();
        r.seconds += elapsed();
        throw;
    }
    st.samples = r.spp - spp_before;
    st.spp = r.spp;
    st.target_reached = target_error > 0 && st.relative_error <= target_error;
    st.seconds = elapsed();  // the whole call, error estimate included
    r.seconds += st.seconds;
    cancel_.store(false);
    return st;
}

void Session::set_part(const SamplePart& part) {
    if (part.job_spp > 0 && !(part.first < part.end && part.end <= part.job_spp))
        throw Error("a part's samples must lie within the job's");
    part_ = part;
    dirty_ = true;
}

bool Session::needs_commit() const {
    return dirty_ || !same(settings_, committed_settings_);
}

void commit_all(const std::vector<Session*>& sessions, size_t first_number) {
    std::vector<std::string> errors(sessions.size());
    std::vector<std::thread> threads;
    for (size_t i = 0; i < sessions.size(); ++i)
        threads.emplace_back([&, i] {
            try {
                sessions[i]->commit();
            } catch (const std::exception& e) {
                errors[i] = e.what();
            }
        });
    for (std::thread& t : threads) t.join();
    for (size_t i = 0; i < errors.size(); ++i)
        if (!errors[i].empty())
            throw Error("device " + std::to_string(first_number + i) + " (" +
                        sessions[i]->device().label() + "): " + errors[i]);
}

PassStats render_until(Session& session, const RenderGoal& goal,
                       const std::function<void(const PassStats&)>& after_step) {
    if (goal.spp == 0 && !(goal.seconds > 0) && !(goal.target_error > 0))
        throw Error("give a sample count, a time budget or a target error");
    // Commit first: the result held below is then the one render() adds to.
    if (session.needs_commit()) session.commit();
    const RenderResult& r = session.result();
    double elapsed = r.seconds;  // a resumed render's time counts
    PassStats st;
    while (!(goal.cancel && goal.cancel->load())) {
        // Steps long enough that their ends (a read-back; on several devices, collecting the
        // sums) cost little.
        const double step = std::max(goal.step_seconds, session.step_seconds());
        const double budget = goal.seconds > 0 ? std::min(step, goal.seconds - elapsed) : step;
        st = session.render(std::max(budget, 0.0) * 1e3, goal.target_error, goal.spp);
        elapsed += st.seconds;
        if (after_step) after_step(st);
        if (st.cancelled || st.target_reached || (goal.spp > 0 && r.spp >= goal.spp) ||
            (goal.seconds > 0 && elapsed >= goal.seconds))
            return st;
    }
    st.cancelled = true;
    return st;
}

void Session::reset() {
    // The scene stays on the device while nothing else changed: new sums, the loop's timings
    // kept (adaptive sampling plans from its warm-up: that starts again with a commit).
    if (dirty_ || !progressive_ || several() || committed_settings_.adaptive || !lost_.empty()) {
        dirty_ = true;
        return;
    }
    progressive_->begin_at(part_.first);
    round_open_ = round_flushed_ = false;
}

const RenderResult& Session::result() const {
    if (several() && progressive_) return total_;
    return progressive_ ? progressive_->result() : empty_;
}

std::vector<float> Session::image_rgba32f() const {
    const RenderResult& r = result();
    const std::vector<float> rgb = r.mean_image();
    std::vector<float> out(rgb.size() / 3 * 4);
    for (size_t i = 0; i < rgb.size() / 3; ++i) {
        for (int c = 0; c < 3; ++c) out[4 * i + c] = rgb[3 * i + c];
        out[4 * i + 3] = 1.f;
    }
    return out;
}

std::vector<uint8_t> Session::image_rgba8() const {
    const std::vector<float> rgba = image_rgba32f();
    std::vector<uint8_t> out(rgba.size());
    for (size_t i = 0; i < rgba.size(); ++i) out[i] = (i % 4 == 3) ? 255 : linear_to_srgb8(rgba[i]);
    return out;
}

void Session::write_image(const std::string& path) const {
    const RenderResult& r = result();
    if (r.spp == 0) throw Error("nothing rendered yet: no image to write");
    mcpt::write_image(path, r.width, r.height, r.mean_image());
}

void Session::save_checkpoint(const std::string& path) {
    if (!progressive_ || result().spp == 0) throw Error("nothing rendered yet: no checkpoint");
    if (committed_settings_.adaptive)
        throw Error(
            "checkpoints keep one sample count for every pixel: an adaptive render "
            "has none to keep");
    if (several()) {
        write_checkpoint(path, fingerprint_of(*this), total_);
        return;
    }
    if (!settings_.reproducible) progressive_->flush();
    RenderResult settled = progressive_->settled();  // with the render time of every call
    settled.seconds = result().seconds;
    write_checkpoint(path, fingerprint_of(*this), settled);
}

Fingerprint Session::fingerprint() const {
    return fingerprint_of(*this);
}

void Session::resume_checkpoint(const std::string& path) {
    if (!has_scene_) throw Error("no scene loaded");
    if (!lost_.empty()) throw DeviceLost("the device stopped earlier (" + lost_ + ")");
    if (dirty_ || !same(settings_, committed_settings_)) commit();
    RenderResult saved = read_checkpoint(path, fingerprint_of(*this));
    if (saved.first != part_.first)
        throw Error("checkpoint '" + path + "' holds samples from " + std::to_string(saved.first) +
                    " on, this render starts at " + std::to_string(part_.first));
    if (several()) {
        if (settings_.reproducible && saved.exact.empty())
            throw Error("checkpoint '" + path + "' holds no exact sums");
        total_ = std::move(saved);
        return;
    }
    progressive_->restore(saved);
}

}  // namespace mcpt
