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
    if (stop_.load() || (lim_.end > 0 && next_first_ >= lim_.end)) return std::nullopt;
    const double g = lim_.granule, rate = stats_[w].rate, now = elapsed();
    // A chunk of about chunk_seconds on this worker; a worker not measured yet takes a small
    // one. With a time limit: none that would end after it (except the job's first), and
    // none longer than the time left.
    double size = rate > 0 ? rate * lim_.chunk_seconds : std::ceil(8 / g) * g;
    if (lim_.seconds > 0 && handed_any_) {
        const double left = lim_.seconds - now;
        if (left <= 0 || (rate > 0 && g / rate > left)) return std::nullopt;
        if (rate > 0) size = std::min(size, rate * left);
    }
    // With a sample count: the rest shared among the workers, so they finish together.
    if (lim_.end > 0) {
        const double left = double(lim_.end - next_first_);
        size = std::min(size, std::max(g, std::ceil(left / double(workers_.size()) / g) * g));
        size = std::min(size, left);
    }
    const uint64_t n = std::max<uint64_t>(lim_.granule, uint64_t(size / g) * lim_.granule);
    const uint64_t end = lim_.end > 0 ? std::min(lim_.end, next_first_ + n) : next_first_ + n;
    const Chunk chunk{next_first_, end};
    next_first_ = end;
    handed_any_ = true;
    ++running_;
    return chunk;
}

void Coordinator::done(size_t w, const Chunk& chunk, RenderResult sums, double seconds) {
    std::lock_guard<std::mutex> lock(mutex_);
    --running_;
    WorkerStats& s = stats_[w];
    ++s.chunks;
    s.samples += sums.spp;
    s.seconds += seconds;
    if (sums.spp > 0 && seconds > 0) s.rate = double(sums.spp) / seconds;
    // A chunk cut short leaves a gap: the chunks after it cannot be added.
    if (sums.first != chunk.first || sums.first + sums.spp < chunk.end) stop_.store(true);
    if (sums.spp > 0 && sums.first == chunk.first) pending_.emplace(chunk.first, std::move(sums));
    reduce();
    if (lim_.target_error > 0 && total_.spp >= 2) {
        total_.materialize();
        if (total_.relative_error() <= lim_.target_error) {
            target_reached_ = true;
            stop_.store(true);
        }
    }
    changed_.notify_all();
}

void Coordinator::reduce() {
    const auto t0 = std::chrono::steady_clock::now();
    while (!pending_.empty() && pending_.begin()->first == total_.first + total_.spp) {
        add_sums(total_, pending_.begin()->second);
        pending_.erase(pending_.begin());
    }
    reduce_s_ += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

void Coordinator::failed(size_t w, const std::string& why, bool device_lost) {
    std::lock_guard<std::mutex> lock(mutex_);
    --running_;
    if (failure_.empty()) {
        failure_ = "device " + std::to_string(w) + " (" + workers_[w]->name() + "): " + why;
        failure_lost_ = device_lost;
    }
    stop_.store(true);
    changed_.notify_all();
}

void Coordinator::cancel() {
    std::lock_guard<std::mutex> lock(mutex_);
    cancelled_ = true;
    stop_.store(true);
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
                    RenderResult sums = workers_[w]->render(*chunk, stop_);
                    const double t =
                        std::chrono::duration<double>(std::chrono::steady_clock::now() - t0)
                            .count();
                    done(w, *chunk, std::move(sums), t);
                } catch (const DeviceLost& e) {
                    failed(w, e.what(), true);
                } catch (const std::exception& e) {
                    failed(w, e.what(), false);
                }
            }
            std::lock_guard<std::mutex> lock(mutex_);
            ++finished;
            changed_.notify_all();
        });
    }
    // Wait for every worker, passing a cancel on.
    {
        std::unique_lock<std::mutex> lock(mutex_);
        while (finished < threads.size()) {
            changed_.wait_for(lock, std::chrono::milliseconds(20));
            if (cancel && cancel->load() && !stop_.load()) cancelled_ = true, stop_.store(true);
        }
    }
    for (std::thread& t : threads) t.join();
    // Chunks after a gap (a failure, a stop) are dropped: the image is a whole prefix.
    pending_.clear();
    total_.materialize();
    if (!failure_.empty()) {
        if (failure_lost_) throw DeviceLost(failure_);
        throw Error(failure_);
    }
}

}  // namespace mcpt
