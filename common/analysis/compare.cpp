#include "common/analysis/compare.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <sstream>
#include <thread>

#include "common/analysis/stats.h"
#include "common/error.h"
#include "common/io/host_cpus.h"

namespace mcpt {

BatchMean batch_mean(const RenderResult& r) {
    BatchMean b;
    b.width = r.width, b.height = r.height, b.spp = r.spp;
    b.nonfinite = r.nonfinite_total, b.seconds = r.seconds, b.rays = r.rays;
    const size_t npix = size_t(r.width) * size_t(r.height);
    b.mean.resize(npix);
    // The mean of r, g, b, each as the image shows it (float).
    for_ranges(npix, [&](size_t begin, size_t end) {
        for (size_t i = begin; i < end; ++i) {
            double m = 0;
            for (int c = 0; c < 3; ++c) m += double(float(channel_stats(r, i, c).mean));
            b.mean[i] = m / 3.0;
        }
    });
    return b;
}

BatchSet batch_means(const std::vector<BatchMean>& batches) {
    if (batches.size() < 2) throw Error("need at least 2 batches");
    BatchSet set;
    set.width = batches[0].width, set.height = batches[0].height;
    set.batches = int(batches.size());
    set.spp_per_batch = batches[0].spp;
    const size_t npix = size_t(set.width) * size_t(set.height);
    for (const BatchMean& b : batches) {
        if (b.width != set.width || b.height != set.height || b.mean.size() != npix)
            throw Error("batches of different image sizes");
        set.nonfinite += b.nonfinite;
        set.seconds += b.seconds;
        set.rays += b.rays;
    }
    // Mean and unbiased variance of the batch means; per pixel the batches in order.
    const double k = set.batches;
    set.mean.resize(npix), set.var.resize(npix);
    for_ranges(npix, [&](size_t begin, size_t end) {
        for (size_t i = begin; i < end; ++i) {
            double sum = 0, sum_sq = 0;
            for (const BatchMean& b : batches) sum += b.mean[i], sum_sq += b.mean[i] * b.mean[i];
            set.mean[i] = sum / k;
            set.var[i] = std::max(0.0, (sum_sq - k * set.mean[i] * set.mean[i]) / (k - 1));
        }
    });
    return set;
}

BatchSet batch_means(const std::vector<RenderResult>& renders) {
    std::vector<BatchMean> batches;
    for (const RenderResult& r : renders) batches.push_back(batch_mean(r));
    return batch_means(batches);
}

BatchSet render_batches(Backend& backend, const GpuScene& scene, const Camera& camera,
                        RenderOptions options, const BatchOptions& batch) {
    if (batch.batches < 2) throw Error("need at least 2 batches");
    backend.load(scene, options.width, options.height, options.group_spp > 0);
    options.spp = batch.spp_per_batch;
    // One batch: an independent render with its own seed.
    std::vector<BatchMean> batches;
    for (int b = 0; b < batch.batches; ++b) {
        options.seed = batch.seed_base + uint32_t(b);
        batches.push_back(batch_mean(render_loaded(backend, scene, camera, options)));
    }
    return batch_means(batches);
}

BatchSet render_batches(Session& session, const BatchOptions& batch) {
    return render_batches(std::vector<Session*>{&session}, batch);
}

BatchSet render_batches(const std::vector<Session*>& sessions, const BatchOptions& batch,
                        const std::function<void(Session&)>& first,
                        const std::vector<BatchRenderer*>& remote,
                        const std::vector<JoiningSession>& joining) {
    if (batch.batches < 2) throw Error("need at least 2 batches");
    if (sessions.empty()) throw Error("no session to render the batches");
    std::vector<BatchMean> batches(size_t(batch.batches));
    std::atomic<int> next{0};
    const size_t devices = sessions.size() + remote.size() + joining.size();
    std::vector<std::string> failures(devices);
    std::vector<int> rendered(devices, 0);
    const auto start = std::chrono::steady_clock::now();
    // Device k takes the next batch while any is left: `one` renders batch b.
    const auto take_batches = [&](size_t k, const std::function<BatchMean(uint32_t seed)>& one) {
        try {
            for (int b;
                 !(batch.cancel && batch.cancel->load()) && (b = next.fetch_add(1)) < batch.batches;
                 ++rendered[k]) {
                batches[size_t(b)] = one(batch.seed_base + uint32_t(b));
                if (batch.on_batch) batch.on_batch();
            }
        } catch (const std::exception& e) {
            failures[k] = e.what();
            next.store(batch.batches);  // the others stop after their batch
        }
    };
    const auto on_session = [&](Session& session) {
        return [&session, &batch](uint32_t seed) {
            session.settings().seed = seed;
            session.reset();
            RenderGoal goal;
            goal.spp = batch.spp_per_batch;
            render_until(session, goal);
            return batch_mean(session.result());
        };
    };
    // Each session in a thread of its own (the first: this thread).
    const auto work = [&](size_t k) {
        try {
            if (k == 0 && first) first(*sessions[0]);
        } catch (const std::exception& e) {
            failures[k] = e.what();
            next.store(batch.batches);
            return;
        }
        take_batches(k, on_session(*sessions[k]));
    };
    const auto work_remote = [&](size_t r) {
        take_batches(sessions.size() + r,
                     [&](uint32_t seed) { return remote[r]->render(seed, batch.spp_per_batch); });
    };
    // A joining device waits while batches are left, then takes them as the others do.
    const auto work_joining = [&](size_t j) {
        const size_t k = sessions.size() + remote.size() + j;
        const auto& ready = joining[j].ready;
        while (ready.wait_for(std::chrono::milliseconds(2)) != std::future_status::ready)
            if (next.load() >= batch.batches || (batch.cancel && batch.cancel->load())) return;
        std::shared_ptr<Session> session;
        try {
            session = ready.get();
        } catch (const std::exception& e) {
            failures[k] = e.what();
            next.store(batch.batches);
            return;
        }
        take_batches(k, on_session(*session));
    };
    std::vector<std::thread> threads;
    for (size_t k = 1; k < sessions.size(); ++k) threads.emplace_back(work, k);
    for (size_t r = 0; r < remote.size(); ++r) threads.emplace_back(work_remote, r);
    for (size_t j = 0; j < joining.size(); ++j) threads.emplace_back(work_joining, j);
    work(0);
    for (std::thread& t : threads) t.join();
    const auto name = [&](size_t k) {
        if (k < sessions.size()) return sessions[k]->device().label();
        if (k < sessions.size() + remote.size()) return remote[k - sessions.size()]->name();
        return joining[k - sessions.size() - remote.size()].name;
    };
    for (size_t k = 0; k < devices; ++k)
        if (!failures[k].empty())
            throw Error(devices == 1
                            ? failures[k]
                            : "device " + std::to_string(k) + " (" + name(k) + "): " + failures[k]);
    // Cancelled: the batches taken were all rendered (each device ends the one it has).
    const int done = std::min(next.load(), batch.batches);
    if (done < batch.batches) batches.resize(size_t(done));
    BatchSet set;
    if (done >= 2) {
        set = batch_means(batches);
    } else {
        set.batches = done;
    }
    set.per_device = rendered;
    if (devices > 1)
        set.seconds =
            std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    return set;
}

std::string Agreement::verdict() const {
    std::ostringstream o;
    o << (agree ? "AGREE" : "DIFFER") << ": min p " << min_p << " (Sidak level " << sidak_level
      << ", " << sidak_rejections << " pixels below), " << bh_discoveries
      << " BH discoveries, mean z " << mean_z_score << ", chi2 z " << chi2_score << " (limit "
      << global_z_limit << "), uniform bias detected with " << 100 * kDetectionPower
      << "% power: " << 100 * detectable_bias << "%";
    if (p_floor >= sidak_level)
        o << "; per pixel, no difference can be told from chance with this few batches (at "
             "least "
          << batches_needed << " a side at this image size)";
    return o.str();
}

Agreement test_agreement(const BatchSet& a, const BatchSet& b, double alpha) {
    // Float rounding: two compilers evaluating the same path differ by a few ulps, which a
    // pixel without sampling noise (a light or its mirror image seen directly) would turn
    // into an infinite z. Each pixel's difference gets this much relative rounding
    // uncertainty on top of its sampling variance.
    constexpr double kRoundingRel = kFloatRoundingTolerance;
    if (a.width != b.width || a.height != b.height) throw Error("images differ in size");
    const size_t npix = a.mean.size();
    Agreement g;
    g.p_image.assign(npix, 1.f);
    g.z_image.assign(npix, 0.f);
    // Per-pixel Welch tests on the batch means, on threads; then the sums in pixel order.
    // Welch's p-values rest on normal batch means. Few batches of few samples are far from
    // normal where a pixel's radiance takes a few values (an edge, a light's rim at 1 spp): all
    // of one side's batches in one mode and all of the other's in the other happens by chance
    // (8 batches a side: in about 3 of 100,000 such pixels), and Welch's test then gives p ~ 1e-10.
    // Where there is sampling noise, its p is floored at the least p-value a permutation test
    // could give; noise-free pixels (a light seen directly) keep theirs: their difference is
    // no chance.
    const auto log_choose = [](double n, double k) {
        return std::lgamma(n + 1) - std::lgamma(k + 1) - std::lgamma(n - k + 1);
    };
    g.p_floor = std::min(1.0, 2 * std::exp(-log_choose(a.batches + b.batches, a.batches)));
    std::vector<double> p(npix, 1.0), z(npix, 0.0), pixel_signal(npix, 0.0);
    std::vector<uint8_t> tested(npix, 0);
    for_ranges(npix, [&](size_t begin, size_t end) {
        for (size_t i = begin; i < end; ++i) {
            if (a.var[i] == 0 && b.var[i] == 0 && a.mean[i] == b.mean[i]) continue;  // no info
            // Rounding variance split over the two sides: adds (tol * mean)^2 to the error^2.
            const double tol = kRoundingRel * std::max(std::abs(a.mean[i]), std::abs(b.mean[i]));
            const double sampling_se2 = a.var[i] / a.batches + b.var[i] / b.batches;
            const stats::Welch w =
                stats::welch_test(b.mean[i], b.var[i] + 0.5 * tol * tol * b.batches, b.batches,
                                  a.mean[i], a.var[i] + 0.5 * tol * tol * a.batches, a.batches);
            const bool noise_free = a.var[i] == 0 && b.var[i] == 0;
            tested[i] = 1, p[i] = noise_free ? w.p : std::max(w.p, g.p_floor), z[i] = w.z;
            // How strongly a relative bias delta would shift this pixel's z: mean / std error
            // (pixels whose error is mostly rounding, not sampling noise, say nothing of that).
            if (w.std_error > 0 && sampling_se2 > tol * tol)
                pixel_signal[i] = 0.5 * (a.mean[i] + b.mean[i]) / w.std_error;
        }
    });
    std::vector<double> p_tested;
    double sum_z = 0, sum_z2 = 0, signal = 0, sum_a = 0, sum_b = 0;
    for (size_t i = 0; i < npix; ++i) {
        sum_a += a.mean[i], sum_b += b.mean[i];
        if (!tested[i]) continue;
        g.p_image[i] = float(p[i]);
        g.z_image[i] = float(std::clamp(z[i], -1e30, 1e30));
        p_tested.push_back(p[i]);
        g.min_p = std::min(g.min_p, p[i]);
        sum_z += z[i], sum_z2 += z[i] * z[i];
        signal += pixel_signal[i];
    }
    const size_t m = p_tested.size();
    g.pixels_tested = m;
    // Three tests share alpha: per-pixel (Sidak), mean of z, sum of z^2.
    const double alpha_each = alpha / 3;
    g.sidak_level = stats::sidak_level(alpha_each, std::max<size_t>(m, 1));
    for (double p : p_tested) g.sidak_rejections += p < g.sidak_level;
    for (int n = 2; n <= 1000 && g.batches_needed == 0; ++n)
        if (2 * std::exp(-log_choose(2 * n, n)) < g.sidak_level) g.batches_needed = n;
    const std::vector<bool> bh = stats::benjamini_hochberg(p_tested, alpha);
    g.bh_discoveries = size_t(std::count(bh.begin(), bh.end(), true));
    g.global_z_limit = stats::normal_quantile(1 - alpha_each / 2);
    if (m > 0) {
        g.mean_z_score = sum_z / std::sqrt(double(m));
        // Wilson-Hilferty: (X/m)^(1/3) is nearly normal for X ~ chi2(m).
        const double md = double(m), v = 2.0 / (9.0 * md);
        g.chi2_score = (std::cbrt(sum_z2 / md) - (1 - v)) / std::sqrt(v);
        // A bias delta shifts the mean z by delta * signal / sqrt(m); the test fires when the
        // shifted N(shift, 1) passes the limit: with kDetectionPower when the shift is the limit
        // plus that power's quantile.
        const double shift = g.global_z_limit + stats::normal_quantile(kDetectionPower);
        g.detectable_bias = signal > 0 ? shift * std::sqrt(md) / signal : INFINITY;
    }
    g.mean_relative_diff = sum_a > 0 ? (sum_b - sum_a) / sum_a : 0;
    g.agree = g.sidak_rejections == 0 && std::abs(g.mean_z_score) < g.global_z_limit &&
              g.chi2_score < g.global_z_limit && a.nonfinite == 0 && b.nonfinite == 0;
    return g;
}

SameSeedDiff same_seed_diff(const RenderResult& a, const RenderResult& b, double tolerance) {
    return difference_maps(a, b, tolerance).same_seed;
}

DifferenceMaps difference_maps(const RenderResult& a, const RenderResult& b, double tolerance) {
    if (a.width != b.width || a.height != b.height) throw Error("images differ in size");
    DifferenceMaps m;
    m.width = a.width, m.height = a.height;
    SameSeedDiff& d = m.same_seed;
    d.tolerance = tolerance;
    const std::vector<float> ia = a.mean_image(), ib = b.mean_image();
    const std::vector<float> ea = a.std_error_image(), eb = b.std_error_image();
    d.pixels = ia.size() / 3;
    m.z.resize(d.pixels), m.relative.resize(d.pixels);
    for (size_t i = 0; i < d.pixels; ++i) {
        // Same seed: the largest relative difference of a channel.
        double relative = 0, ma = 0, mb = 0, sa = 0, sb = 0;
        for (int c = 0; c < 3; ++c) {
            const double x = ia[3 * i + c], y = ib[3 * i + c];
            const double diff = std::abs(x - y);
            d.max_abs_diff = std::max(d.max_abs_diff, diff);
            relative = std::max(relative, diff / std::max({std::abs(x), std::abs(y), 1e-3}));
            ma += x / 3, mb += y / 3, sa += ea[3 * i + c] / 3, sb += eb[3 * i + c] / 3;
        }
        m.relative[i] = float(relative);
        d.diverged += relative > tolerance;
        // The standardized difference of the channel means.
        const double rounding = kFloatRoundingTolerance * std::max(std::abs(ma), std::abs(mb));
        const double sigma = std::sqrt(sa * sa + sb * sb + rounding * rounding);
        m.z[i] = sigma > 0 ? float((mb - ma) / sigma) : 0.f;
    }
    return m;
}

}  // namespace mcpt
