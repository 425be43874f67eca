#include "common/render/coordinator.h"

#include <algorithm>
#include <cmath>
#include <thread>

#include "common/error.h"

namespace mcpt {

Coordinator::Coordinator(RenderResult& total, const JobLimits& limits,
                         const std::vector<Worker*>& workers, const std::vector<double>& rates)
    : total_(total), lim_(limits), workers_(workers), start_(std::chrono::steady_clock::now()) {
    if (workers_.empty()) throw Error("a job needs at least one device");
    lim_.granule = std::max(1u, lim_.granule);
    next_first_ = total_.first + total_.spp;
    stats_.resize(workers_.size());
    busy_until_.assign(workers_.size(), 0.0);
    for (size_t w = 0; w < workers_.size(); ++w) {
        stats_[w].name = workers_[w]->name();
        if (w < rates.size()) stats_[w].rate = rates[w];
    }
}

double Coordinator::elapsed() const {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
}

std::optional<Chunk> Coordinator::next(size_t w) {
    std::lock_guard<std::mutex> lock(mutex_);
    if (stop_ || (lim_.end > 0 && next_first_ >= lim_.end)) return std::nullopt;
    const double g = lim_.granule, rate = stats_[w].rate, now = elapsed();
    // A chunk of about chunk_seconds on this worker; a worker not measured yet takes a small
    // one. With a time limit: none that would end after it (except the round's first), and
    // none longer than the time left.
    double size = rate > 0 ? rate * lim_.chunk_seconds : std::ceil(8 / g) * g;
    if (lim_.seconds > 0 && handed_any_) {
        const double left = lim_.seconds - now;
        if (left <= 0 || (rate > 0 && g / rate > left)) {
            out_of_time_ = true;
            return std::nullopt;
        }
        if (rate > 0) size = std::min(size, rate * left);
    }
    // With a sample count: this worker's share of the rest, so that all finish together.
    if (lim_.end > 0) {
        const double left = double(lim_.end - next_first_), share = share_of_rest(w, left, now);
        if (!(share > 0)) return std::nullopt;
        size = std::min(size, std::max(g, std::ceil(share / g) * g));
        size = std::min(size, left);
    }
    const uint64_t n = std::max<uint64_t>(lim_.granule, uint64_t(size / g) * lim_.granule);
    const uint64_t end = lim_.end > 0 ? std::min(lim_.end, next_first_ + n) : next_first_ + n;
    const Chunk chunk{next_first_, end};
    next_first_ = end;
    handed_any_ = true;
    // When it should be free again (its speed, or its peers' while unmeasured).
    const double speed = rate > 0 ? rate : mean_rate();
    busy_until_[w] = speed > 0 ? now + double(end - chunk.first) / speed : now;
    return chunk;
}

double Coordinator::mean_rate() const {
    double sum = 0;
    int known = 0;
    for (const WorkerStats& s : stats_)
        if (s.rate > 0) sum += s.rate, ++known;
    return known > 0 ? sum / known : 0;
}

double Coordinator::share_of_rest(size_t w, double left, double now) const {
    // Nothing measured yet: an equal split.
    const double mean = mean_rate();
    if (!(mean > 0)) return left / double(workers_.size());
    // Each worker from when it is free (this one now, the others when their chunks should
    // end), at its speed (its peers' while unmeasured), sorted by that time, this one first.
    struct Free {
        double at, rate;
        size_t w;
    };
    std::vector<Free> free;
    for (size_t i = 0; i < workers_.size(); ++i)
        free.push_back({i == w ? now : std::max(now, busy_until_[i]),
                        stats_[i].rate > 0 ? stats_[i].rate : mean, i});
    // At one time the measured first (an unmeasured worker's speed is a guess), then w.
    const auto measured = [this](const Free& f) { return stats_[f.w].rate > 0; };
    std::sort(free.begin(), free.end(), [&](const Free& a, const Free& b) {
        if (a.at != b.at) return a.at < b.at;
        if (measured(a) != measured(b)) return measured(a);
        return (a.w == w) > (b.w == w);
    });
    // The common end T: the workers free before it render rate * (T - at) each, `left` in all.
    double rates = 0, weighted = 0, end = now;
    size_t k = 0;
    for (; k < free.size() && (k == 0 || free[k].at < end); ++k) {
        rates += free[k].rate, weighted += free[k].rate * free[k].at;
        end = (left + weighted) / rates;
    }
    // The last to join sit out while their part would be shorter than a collection costs.
    while (k > 1 && end - free[k - 1].at < lim_.min_share_seconds) {
        --k;
        rates -= free[k].rate, weighted -= free[k].rate * free[k].at;
        end = (left + weighted) / rates;
    }
    // w's part, or none: it sits this round out.
    for (size_t i = 0; i < k; ++i)
        if (free[i].w == w) return free[i].rate * (end - now);
    return 0;
}

void Coordinator::done(size_t w, const Chunk& chunk, double seconds) {
    std::lock_guard<std::mutex> lock(mutex_);
    WorkerStats& s = stats_[w];
    ++s.chunks;
    s.samples += chunk.end - chunk.first;
    s.seconds += seconds;
    // A chunk's time holds a fixed cost (its first dispatch waits, its passes start): a short
    // chunk's speed is a lower bound, taken only where it is higher than the speed known.
    if (seconds > 0) {
        const double rate = double(chunk.end - chunk.first) / seconds;
        if (seconds >= kShortChunkSeconds || rate > s.rate) s.rate = rate;
    }
}

void Coordinator::failed(size_t w, const std::string& why, bool device_lost) {
    std::lock_guard<std::mutex> lock(mutex_);
    if (failure_.empty()) {
        failure_ = "device " + std::to_string(w) + " (" + workers_[w]->name() + "): " + why;
        failure_lost_ = device_lost;
    }
    stop_ = true;
    changed_.notify_all();
}

std::vector<double> Coordinator::rates() const {
    std::vector<double> r;
    for (const WorkerStats& s : stats_) r.push_back(s.rate);
    return r;
}

void Coordinator::run(const std::atomic<bool>* cancel) {
    size_t finished = 0;
    std::vector<std::thread> threads;
    for (size_t w = 0; w < workers_.size(); ++w) {
        threads.emplace_back([this, w, &finished] {
            while (const std::optional<Chunk> chunk = next(w)) {
                const auto t0 = std::chrono::steady_clock::now();
                try {
                    workers_[w]->render(*chunk);
                } catch (const DeviceLost& e) {
                    failed(w, e.what(), true);
                    break;
                } catch (const std::exception& e) {
                    failed(w, e.what(), false);
                    break;
                }
                done(w, *chunk,
                     std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
            }
            // No chunk left for it: its read-back overlaps the others' last chunks.
            const auto t0 = std::chrono::steady_clock::now();
            try {
                workers_[w]->finish_round();
            } catch (const DeviceLost& e) {
                failed(w, e.what(), true);
            } catch (const std::exception& e) {
                failed(w, e.what(), false);
            }
            const double finish_s =
                std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
            std::lock_guard<std::mutex> lock(mutex_);
            stats_[w].finish_seconds += finish_s;
            ++finished;
            changed_.notify_all();
        });
    }
    // Wait for every worker, passing a cancel on (no new chunks; running ones finish).
    {
        std::unique_lock<std::mutex> lock(mutex_);
        while (finished < threads.size()) {
            changed_.wait_for(lock, std::chrono::milliseconds(20));
            if (cancel && cancel->load() && !stop_) cancelled_ = stop_ = true;
        }
    }
    for (std::thread& t : threads) t.join();
    if (!failure_.empty()) {
        if (failure_lost_) throw DeviceLost(failure_);
        throw Error(failure_);
    }
    // Every chunk handed out is done: the devices' sums together hold [start, next_first_),
    // added straight to the total (exact sums in any order give the same bits).
    const auto t0 = std::chrono::steady_clock::now();
    const uint64_t before = total_.spp, expected = next_first_ - (total_.first + total_.spp);
    // The sums this process holds in one pass over the image, the others' as they come.
    std::vector<const RenderResult*> held;
    std::vector<Worker*> holders;
    for (Worker* w : workers_) {
        if (const RenderResult* sums = w->round_sums())
            held.push_back(sums), holders.push_back(w);
        else
            w->add_round_to(total_);
    }
    accumulate_sums(total_, held);
    for (Worker* w : holders) w->start_round();
    if (total_.spp - before != expected) {
        const uint64_t got = total_.spp - before;
        total_ = RenderResult{};  // a device counted wrong: none of the sums can be trusted
        throw Error("the devices returned " + std::to_string(got) + " samples per pixel, " +
                    std::to_string(expected) + " were handed out: the image is dropped");
    }
    reduce_s_ += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    total_.materialize();
}

}  // namespace mcpt
