#include "common/view/live_render.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>

#include "common/error.h"

namespace mcpt {

namespace {
// A render step: long enough that its end (a read-back, the error estimate, a copy of the sums
// when a viewer asked for one) costs little, short enough for two new images a second.
constexpr double kStepSeconds = 0.5;
// Milestones a side keeps while the other has not reached them (the slower side meets them):
// the oldest (the next the other side reaches) and the newest.
constexpr size_t kMaxMilestones = 8;
// Points of a side's error curve: at twice this many, every other one is dropped (the first
// and the last kept), so a long run's curve stays evenly spaced and small.
constexpr size_t kMaxSeriesPoints = 1024;
// The window over which a side's current rates are measured.
constexpr double kRateWindowSeconds = 1.0;

// The sums of a result without its exact fixed-point copy (not needed to look at).
std::shared_ptr<RenderResult> copy_sums(const RenderResult& r) {
    auto c = std::make_shared<RenderResult>();
    c->width = r.width, c->height = r.height;
    c->spp = r.spp, c->first = r.first, c->seconds = r.seconds;
    c->sum = r.sum, c->sum_sq = r.sum_sq, c->nonfinite = r.nonfinite, c->samples = r.samples;
    c->rays = r.rays, c->nonfinite_total = r.nonfinite_total;
    return c;
}
}  // namespace

uint64_t next_milestone(uint64_t spp) {
    // One sequence for both sides, whatever count a side's step ended at: a step that ran out
    // of time before its milestone must aim at the same one again (grown from where it stood,
    // a side slower than a step per milestone left the sequence and met the other no more).
    uint64_t m = 4;
    while (m <= spp) m = std::max(m + 4, (m + m / 4 + 3) / 4 * 4);
    return m;
}

LiveRender::LiveRender(std::vector<std::unique_ptr<Session>> sessions, uint64_t max_spp)
    : max_spp_(max_spp) {
    // Tests: side B made N times slower (it waits N - 1 times each step's time after it), as
    // a slower device would be.
    if (const char* slow = std::getenv("MCPT_VIEW_SLOW_B"))
        b_slowdown_ = std::max(1.0, std::atof(slow));
    if (sessions.empty() || sessions.size() > 2) throw Error("a live render has one or two sides");
    for (auto& s : sessions) {
        if (!s) throw Error("a live render needs sessions");
        sides_.push_back(std::make_unique<Side>());
        sides_.back()->session = std::move(s);
    }
}

LiveRender::~LiveRender() {
    stop();
}

std::string LiveRender::label(size_t side) const {
    const DeviceInfo& d = sides_.at(side)->session->device();
    return d.label();
}

void LiveRender::start() {
    for (size_t s = 0; s < sides_.size(); ++s)
        if (!sides_[s]->thread.joinable()) sides_[s]->thread = std::thread([this, s] { run(s); });
}

void LiveRender::stop() {
    stopping_.store(true);
    published_.notify_all();
    for (auto& side : sides_) side->session->cancel();
    wake_.notify_all();
    for (auto& side : sides_)
        if (side->thread.joinable()) side->thread.join();
}

void LiveRender::set_paused(bool paused) {
    paused_.store(paused);
    wake_.notify_all();
}

void LiveRender::reset() {
    std::lock_guard<std::mutex> lock(mutex_);
    ++generation_;
    for (auto& side : sides_) {
        side->session->cancel();  // ends the step under way
        side->series.clear(), side->milestones.clear(), side->snapshot.reset();
        side->devices.clear();
        side->window_seconds = side->window_samples = side->window_rays = 0;
        side->last_samples = side->last_rays = 0;
        side->rates = LiveRates{};
        side->wanted.store(true);
    }
    met_[0].reset(), met_[1].reset(), maps_.reset();
    wake_.notify_all();
}

std::shared_ptr<const LiveSnapshot> LiveRender::snapshot(size_t side) {
    Side& s = *sides_.at(side);
    s.wanted.store(true);
    std::lock_guard<std::mutex> lock(mutex_);
    return s.snapshot;
}

std::shared_ptr<const LiveSnapshot> LiveRender::next_snapshot(size_t side, uint64_t since,
                                                              double timeout_s) {
    Side& s = *sides_.at(side);
    s.wanted.store(true);
    std::unique_lock<std::mutex> lock(mutex_);
    published_.wait_for(lock, std::chrono::duration<double>(timeout_s), [&] {
        return stopping_.load() || (s.snapshot && s.snapshot->serial != since);
    });
    return s.snapshot;
}

std::shared_ptr<const LiveSnapshot> LiveRender::latest(size_t side) const {
    std::lock_guard<std::mutex> lock(mutex_);
    return sides_.at(side)->snapshot;
}

std::vector<ErrorPoint> LiveRender::error_series(size_t side) const {
    std::lock_guard<std::mutex> lock(mutex_);
    return sides_.at(side)->series;
}

std::vector<WorkerStats> LiveRender::device_stats(size_t side) const {
    std::lock_guard<std::mutex> lock(mutex_);
    return sides_.at(side)->devices;
}

LiveRates LiveRender::rates(size_t side) const {
    std::lock_guard<std::mutex> lock(mutex_);
    return sides_.at(side)->rates;
}

std::shared_ptr<const LiveMaps> LiveRender::maps() {
    std::shared_ptr<const RenderResult> a, b;
    {
        std::lock_guard<std::mutex> lock(mutex_);
        if (!met_[0] || (maps_ && maps_->spp == met_[0]->spp)) return maps_;
        a = met_[0], b = met_[1];
    }
    // Computed outside the lock, on the caller's thread.
    auto m = std::make_shared<LiveMaps>();
    m->spp = a->spp;
    m->maps = difference_maps(*a, *b);
    std::lock_guard<std::mutex> lock(mutex_);
    if (met_[0] == a) maps_ = m;
    return m;
}

bool LiveRender::done() const {
    std::lock_guard<std::mutex> lock(mutex_);
    if (max_spp_ == 0) return false;
    for (const auto& side : sides_)
        if (!side->snapshot || side->snapshot->result.spp < max_spp_) return false;
    return true;
}

std::string LiveRender::failure() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return failure_;
}

void LiveRender::publish(size_t s, uint64_t generation, double relative_error,
                         double step_seconds) {
    Side& side = *sides_[s];
    const RenderResult& r = side.session->result();
    // The error curve gets every step; a snapshot only when a viewer asked for one since the
    // last ...
    // ... and always before the side waits (paused, or at its last sample), so that a viewer
    // asking later sees where it stopped.
    const bool idle = paused_.load() || (max_spp_ > 0 && r.spp >= max_spp_);
    std::shared_ptr<LiveSnapshot> snap;
    if (side.wanted.exchange(false) || idle) {
        snap = std::make_shared<LiveSnapshot>();
        snap->result = std::move(*copy_sums(r));
        snap->relative_error = relative_error;
    }
    std::vector<WorkerStats> devices = side.session->device_stats();
    std::lock_guard<std::mutex> lock(mutex_);
    if (generation != generation_) return;  // reset meanwhile: these samples are dropped
    // The current rates: this step joins the window; a full window becomes the rates (the
    // first one, until full, shows what it has).
    const double samples = double(r.spp) * r.width * r.height;
    side.window_seconds += step_seconds;
    side.window_samples += samples - side.last_samples;
    side.window_rays += r.rays - side.last_rays;
    side.last_samples = samples, side.last_rays = r.rays;
    const bool first = side.rates.samples_per_second == 0 && side.rates.rays_per_second == 0;
    if (side.window_seconds > 0 && (first || side.window_seconds >= kRateWindowSeconds)) {
        side.rates.samples_per_second = side.window_samples / side.window_seconds;
        side.rates.rays_per_second = side.window_rays / side.window_seconds;
        if (side.window_seconds >= kRateWindowSeconds)
            side.window_seconds = side.window_samples = side.window_rays = 0;
    }
    if (snap) {
        snap->samples_per_second = side.rates.samples_per_second;
        snap->rays_per_second = side.rates.rays_per_second;
    }
    side.series.push_back({r.seconds, r.spp, relative_error});
    side.devices = std::move(devices);
    if (side.series.size() >= 2 * kMaxSeriesPoints) {
        std::vector<ErrorPoint>& v = side.series;
        size_t kept = 0;
        for (size_t i = 0; i + 1 < v.size(); i += 2) v[kept++] = v[i];
        v[kept++] = v.back();
        v.resize(kept);
    }
    if (snap) {
        snap->serial = ++side.serial;
        side.snapshot = snap;
        published_.notify_all();
    }
}

void LiveRender::reach_milestone(size_t s, uint64_t spp, uint64_t generation) {
    // A copy of the sums at the milestone, met now or kept until the other side reaches it.
    std::shared_ptr<const RenderResult> here = copy_sums(sides_[s]->session->result());
    std::lock_guard<std::mutex> lock(mutex_);
    if (generation != generation_) return;
    Side& other = *sides_[1 - s];
    auto it = other.milestones.find(spp);
    if (it != other.milestones.end()) {
        met_[s] = here, met_[1 - s] = it->second;
        // Older milestones can no longer be the latest met.
        other.milestones.erase(other.milestones.begin(), std::next(it));
        return;
    }
    // Over the limit, one between the oldest and the newest goes: the one whose neighbours are
    // closest (as a ratio), so the kept ones stay spread evenly in log(spp). The oldest stays:
    // the other side reaches every milestone in turn and meets that one next, then the next
    // kept (dropping the oldest, a side more than about six times faster dropped every
    // milestone before the slower one got there, and the maps never appeared).
    auto& mine = sides_[s]->milestones;
    mine[spp] = here;
    if (mine.size() > kMaxMilestones) {
        auto drop = std::next(mine.begin());
        double closest = HUGE_VAL;
        for (auto it = std::next(mine.begin()); std::next(it) != mine.end(); ++it) {
            const double span = double(std::next(it)->first) / double(std::prev(it)->first);
            if (span < closest) closest = span, drop = it;
        }
        mine.erase(drop);
    }
}

void LiveRender::run(size_t s) {
    Side& side = *sides_[s];
    Session& session = *side.session;
    const bool ab = sides_.size() == 2;
    uint64_t generation = 0;
    try {
        while (!stopping_.load()) {
            // Wait while paused or done; start over after a reset.
            {
                std::unique_lock<std::mutex> lock(mutex_);
                wake_.wait(lock, [&] {
                    const bool done =
                        max_spp_ > 0 && session.spp() >= max_spp_ && generation == generation_;
                    return stopping_.load() || (!paused_.load() && !done);
                });
                if (stopping_.load()) break;
                if (generation != generation_) {
                    generation = generation_;
                    session.reset();
                }
            }
            // A step; an A/B side stops at the next milestone (or the last sample), where it
            // meets the other.
            uint64_t cap = max_spp_;
            if (ab) {
                const uint64_t milestone = next_milestone(session.spp());
                cap = cap > 0 ? std::min(cap, milestone) : milestone;
            }
            const double step_ms = 1e3 * std::max(kStepSeconds, session.step_seconds());
            const auto step_start = std::chrono::steady_clock::now();
            const double rendered_before = session.spp() > 0 ? session.result().seconds : 0.0;
            const PassStats st = session.render(step_ms, 0, cap);
            if (s == 1 && b_slowdown_ > 1) {
                // N times the render time (not the kernel build a first step includes).
                const double took = std::max(0.0, session.result().seconds - rendered_before);
                std::unique_lock<std::mutex> lock(mutex_);
                wake_.wait_for(lock, std::chrono::duration<double>(took * (b_slowdown_ - 1)),
                               [&] { return stopping_.load(); });
            }
            const double step_wall = std::chrono::duration<double>(
                                         std::chrono::steady_clock::now() - step_start)
                                         .count();
            if (session.spp() == 0) continue;
            if (ab && session.spp() == cap) reach_milestone(s, cap, generation);
            publish(s, generation, st.relative_error, step_wall);
        }
    } catch (const std::exception& e) {
        std::lock_guard<std::mutex> lock(mutex_);
        if (failure_.empty()) failure_ = std::string(ab ? (s == 0 ? "A: " : "B: ") : "") + e.what();
    }
}

}  // namespace mcpt
