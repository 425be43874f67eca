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
    // With a sample count: the rest shared among the workers, so they finish together.
    if (lim_.end > 0) {
        const double left = double(lim_.end - next_first_);
        double sharers = double(workers_.size());
        if (rate > 0 && lim_.min_share_seconds > 0)
            sharers = std::clamp(std::floor(left / (rate * lim_.min_share_seconds)), 1.0, sharers);
        size = std::min(size, std::max(g, std::ceil(left / sharers / g) * g));
        size = std::min(size, left);
    }
    const uint64_t n = std::max<uint64_t>(lim_.granule, uint64_t(size / g) * lim_.granule);
    const uint64_t end = lim_.end > 0 ? std::min(lim_.end, next_first_ + n) : next_first_ + n;
    const Chunk chunk{next_first_, end};
    next_first_ = end;
    handed_any_ = true;
    return chunk;
}

void Coordinator::done(size_t w, const Chunk& chunk, double seconds) {
    std::lock_guard<std::mutex> lock(mutex_);
    WorkerStats& s = stats_[w];
    ++s.chunks;
    s.samples += chunk.end - chunk.first;
    s.seconds += seconds;
    if (seconds > 0) s.rate = double(chunk.end - chunk.first) / seconds;
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
            try {
                workers_[w]->finish_round();
            } catch (const DeviceLost& e) {
                failed(w, e.what(), true);
            } catch (const std::exception& e) {
                failed(w, e.what(), false);
            }
            std::lock_guard<std::mutex> lock(mutex_);
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
    for (Worker* w : workers_) w->add_round_to(total_);
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
