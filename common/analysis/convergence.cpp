#include "common/analysis/convergence.h"

#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>

#include "common/error.h"
#include "common/render/gpu_scene.h"

namespace mcpt {

// ---- references

double Reference::mean_value() const {
    double s = 0;
    for (double v : mean) s += v;
    return mean.empty() ? 0 : s / double(mean.size());
}

double Reference::noise_variance() const {
    double s = 0;
    for (double v : variance) s += v;
    return variance.empty() ? 0 : s / double(variance.size());
}

Reference constant_reference(int width, int height, double value, const std::string& source) {
    Reference r;
    r.width = width, r.height = height;
    r.mean.assign(3 * size_t(width) * size_t(height), value);
    r.variance.assign(r.mean.size(), 0.0);
    r.source = source;
    return r;
}

Reference reference_from_render(const RenderResult& render, const std::string& source) {
    Reference r;
    r.width = render.width, r.height = render.height;
    r.spp = render.spp;
    r.source = source;
    const std::vector<float> img = render.mean_image(), err = render.std_error_image();
    r.mean.assign(img.begin(), img.end());
    r.variance.resize(err.size());
    for (size_t i = 0; i < err.size(); ++i) r.variance[i] = double(err[i]) * err[i];
    return r;
}

bool exact_furnace_radiance(const Scene& scene, double& value) {
    // Every material the same grey diffuse emitter.
    if (scene.name != "furnace" || scene.materials.empty()) return false;
    const Material& m0 = scene.materials[0];
    for (const Material& m : scene.materials) {
        if (m.type != MaterialType::Diffuse || m.color != m0.color || m.emission != m0.emission)
            return false;
    }
    const float rho = m0.color.x, le = m0.emission.x;
    if (m0.color != glm::vec3(rho) || m0.emission != glm::vec3(le) || !(rho < 1.f)) return false;
    value = double(le) / (1.0 - double(rho));
    return true;
}

std::string reference_cache_dir() {
    if (const char* x = std::getenv("XDG_CACHE_HOME"); x && *x) return std::string(x) + "/mcpt";
    if (const char* h = std::getenv("HOME"); h && *h) return std::string(h) + "/.cache/mcpt";
    return (std::filesystem::temp_directory_path() / "mcpt-cache").string();
}

namespace {

struct Fnv {
    uint64_t h = 1469598103934665603ull;
    void add(const void* data, size_t n) {
        const auto* p = static_cast<const unsigned char*>(data);
        for (size_t i = 0; i < n; ++i) h = (h ^ p[i]) * 1099511628211ull;
    }
    template <class T>
    void add_vec(const std::vector<T>& v) {
        const uint64_t n = v.size();
        add(&n, sizeof n);
        if (!v.empty()) add(v.data(), v.size() * sizeof(T));
    }
};

constexpr char kRefMagic[8] = {'M', 'C', 'P', 'T', 'R', 'E', 'F', '1'};

}  // namespace

uint64_t reference_key(const GpuScene& scene, const Camera& camera, int width, int height,
                       uint32_t max_depth, uint32_t rr_depth, const std::string& extra) {
    // Content only: the tree changes speed, never the image.
    Fnv f;
    f.add_vec(scene.triangles), f.add_vec(scene.spheres);
    f.add_vec(scene.materials), f.add_vec(scene.lights);
    gpu::GpuParams p = scene.params;
    p.num_nodes = 0;
    set_camera(p, camera, width, height);
    p.max_depth = max_depth, p.rr_depth = rr_depth;
    f.add(&p, sizeof p);
    f.add(extra.data(), extra.size());
    return f.h;
}

bool load_reference(const std::string& path, int width, int height, Reference& out) {
    // Magic, size, spp, then mean and variance as doubles.
    std::ifstream in(path, std::ios::binary);
    if (!in) return false;
    char magic[8];
    int32_t w = 0, h = 0;
    uint64_t spp = 0;
    in.read(magic, 8);
    in.read(reinterpret_cast<char*>(&w), 4), in.read(reinterpret_cast<char*>(&h), 4);
    in.read(reinterpret_cast<char*>(&spp), 8);
    if (!in || std::memcmp(magic, kRefMagic, 8) != 0 || w != width || h != height) return false;
    Reference r;
    r.width = w, r.height = h, r.spp = spp;
    r.mean.resize(3 * size_t(w) * size_t(h)), r.variance.resize(r.mean.size());
    in.read(reinterpret_cast<char*>(r.mean.data()), std::streamsize(r.mean.size() * 8));
    in.read(reinterpret_cast<char*>(r.variance.data()), std::streamsize(r.variance.size() * 8));
    if (!in) return false;
    r.source = "cached " + path + " (" + std::to_string(spp) + " spp)";
    out = std::move(r);
    return true;
}

void save_reference(const std::string& path, const Reference& ref) {
    std::error_code ec;
    std::filesystem::create_directories(std::filesystem::path(path).parent_path(), ec);
    const std::string tmp = path + ".tmp" + std::to_string(::getpid());
    {
        std::ofstream o(tmp, std::ios::binary);
        const int32_t w = ref.width, h = ref.height;
        const uint64_t spp = ref.spp;
        o.write(kRefMagic, 8);
        o.write(reinterpret_cast<const char*>(&w), 4),
            o.write(reinterpret_cast<const char*>(&h), 4);
        o.write(reinterpret_cast<const char*>(&spp), 8);
        o.write(reinterpret_cast<const char*>(ref.mean.data()),
                std::streamsize(ref.mean.size() * 8));
        o.write(reinterpret_cast<const char*>(ref.variance.data()),
                std::streamsize(ref.variance.size() * 8));
        if (!o) throw Error("cannot write reference cache '" + tmp + "'");
    }
    std::filesystem::rename(tmp, path, ec);
    if (ec) throw Error("cannot write reference cache '" + path + "': " + ec.message());
}

// ---- error of a render

ErrorMetrics measure_error(const RenderResult& render, const Reference& ref) {
    if (render.width != ref.width || render.height != ref.height)
        throw Error("reference and render differ in size");
    const std::vector<float> img = render.mean_image();
    double sq = 0, rel = 0, rel_noise = 0, signed_sum = 0;
    for (size_t i = 0; i < img.size(); ++i) {
        // Squared, relative and signed error; the reference's own variance per pixel.
        const double d = double(img[i]) - ref.mean[i];
        const double w = 1.0 / (ref.mean[i] * ref.mean[i] + 1e-2);
        sq += d * d, rel += d * d * w, rel_noise += ref.variance[i] * w, signed_sum += d;
    }
    const double n = double(std::max<size_t>(1, img.size()));
    ErrorMetrics e;
    e.reference_noise = std::sqrt(ref.noise_variance());
    e.mse = std::max(0.0, sq / n - ref.noise_variance());
    e.rmse = std::sqrt(e.mse);
    e.rel_mse = std::max(0.0, (rel - rel_noise) / n);
    const double m = ref.mean_value();
    e.rel_rmse = m > 0 ? e.rmse / m : 0;
    e.mean_signed_error = signed_sum / n;
    return e;
}

void accumulate(RenderResult& total, const RenderResult& b) {
    if (total.sum.empty()) {
        total = b;
        return;
    }
    if (total.width != b.width || total.height != b.height)
        throw Error("cannot accumulate renders of different sizes");
    for (size_t i = 0; i < total.sum.size(); ++i)
        total.sum[i] += b.sum[i], total.sum_sq[i] += b.sum_sq[i];
    for (size_t i = 0; i < total.nonfinite.size(); ++i) total.nonfinite[i] += b.nonfinite[i];
    total.spp += b.spp, total.seconds += b.seconds, total.rays += b.rays;
    total.nonfinite_total += b.nonfinite_total;
}

double effective_pixels(const RenderResult& r) {
    // Participation ratio of the per-pixel sample variances.
    const std::vector<float> err = r.std_error_image();
    double s = 0, s2 = 0;
    for (size_t i = 0; i + 2 < err.size(); i += 3) {
        const double v = (double(err[i]) * err[i] + double(err[i + 1]) * err[i + 1] +
                          double(err[i + 2]) * err[i + 2]) /
                         3.0;
        s += v, s2 += v * v;
    }
    return s2 > 0 ? s * s / s2 : double(err.size() / 3);
}

// ---- progressive rendering

std::vector<Checkpoint> render_progressive(Session& session, const ProgressiveOptions& opt,
                                           const Reference& ref, RenderResult* total_out,
                                           const std::function<void(const Checkpoint&)>& on_cp) {
    const bool by_time = opt.schedule == Schedule::TimeDoubling;
    if (opt.max_spp == 0 && !(opt.seconds > 0)) throw Error("give a sample count or a time budget");
    if (by_time && !(opt.seconds > 0)) throw Error("time checkpoints need a time budget");
    std::vector<Checkpoint> cps;
    // One sample sequence (one seed), continued from checkpoint to checkpoint: a
    // low-discrepancy sampler keeps its stratification across them.
    session.settings().seed = opt.seed_base;
    session.reset();
    session.commit();
    const RenderResult& total = session.result();
    // The render loop of `mcpt render` (render_until), in as few steps as it allows: the time
    // is the sessions' render time (measuring the error is left out).
    auto render_to = [&](uint64_t spp, double until_s) {
        RenderGoal goal;
        goal.spp = spp, goal.seconds = until_s;
        goal.step_seconds = until_s > 0 ? until_s : 3600;
        goal.cancel = opt.cancel;
        render_until(session, goal);
    };
    const int n_time = std::max(1, opt.time_checkpoints);
    bool last = false;
    for (int k = 0; !last; ++k) {
        // Next checkpoint: double the samples (or reach the next time checkpoint), within budget.
        const double seconds = total.seconds;
        const double remaining = opt.seconds - seconds;
        if (by_time) {
            if (k >= n_time) break;
            const double t_k = opt.seconds * std::ldexp(1.0, k - (n_time - 1));
            if (t_k <= seconds) continue;
            render_to(0, t_k);
        } else {
            uint64_t want = std::max<uint64_t>(1, total.spp);
            if (opt.max_spp > 0) want = std::min(want, opt.max_spp - total.spp);
            if (opt.seconds > 0 && total.spp > 0) {
                const double per_spp = seconds / double(total.spp);
                // A last, shorter stretch only if it adds at least a quarter of the samples.
                if (double(want) * per_spp > remaining) {
                    if (remaining < 0.25 * seconds) break;
                    last = true;
                }
            }
            if (last)
                render_to(0, opt.seconds);
            else
                render_to(total.spp + want, 0);
        }
        // Cancelled before a sample more: nothing new to measure.
        if (opt.cancel && opt.cancel->load() &&
            (total.spp == 0 || (!cps.empty() && cps.back().spp == total.spp)))
            break;
        cps.push_back({total.seconds, total.spp, measure_error(total, ref)});
        if (on_cp) on_cp(cps.back());
        // Stop at the sample or time budget, or once cancelled.
        if (opt.cancel && opt.cancel->load()) break;
        if (opt.max_spp > 0 && total.spp >= opt.max_spp) break;
        if (opt.seconds > 0 && total.seconds >= opt.seconds) break;
    }
    if (total_out) *total_out = total;
    return cps;
}

// ---- analysis

double LogLogFit::at(double x) const {
    return std::exp(intercept + slope * std::log(x));
}

LogLogFit fit_loglog(const std::vector<double>& x, const std::vector<double>& y) {
    double sx = 0, sy = 0, sxx = 0, sxy = 0;
    LogLogFit f;
    for (size_t i = 0; i < std::min(x.size(), y.size()); ++i) {
        if (!(x[i] > 0 && y[i] > 0)) continue;
        const double lx = std::log(x[i]), ly = std::log(y[i]);
        sx += lx, sy += ly, sxx += lx * lx, sxy += lx * ly;
        ++f.points;
    }
    if (f.points == 0) return f;
    const double n = double(f.points), den = n * sxx - sx * sx;
    f.slope = f.points >= 2 && den > 0 ? (n * sxy - sx * sy) / den : 0;
    f.intercept = (sy - f.slope * sx) / n;
    return f;
}

std::string ConvergenceReport::verdict() const {
    char buf[256];
    if (biased) {
        std::snprintf(buf, sizeof buf,
                      "biased: estimated bias = %+.4g (%+.2f%% of the reference); local slope "
                      "%.3f > -0.25 above the noise floor",
                      estimated_bias, 100 * relative_bias, local_slope);
    } else {
        std::snprintf(buf, sizeof buf,
                      "consistent: slope vs spp %.3f (ideal -0.5, expected spread %.3f), local "
                      "slope %.3f",
                      spp_fit.slope, slope_sigma, local_slope);
    }
    return buf;
}

ConvergenceReport analyze_convergence(const std::vector<Checkpoint>& cps, double reference_mean,
                                      double pixels) {
    ConvergenceReport r;
    std::vector<double> t, s, e;
    for (const Checkpoint& c : cps)
        t.push_back(c.seconds), s.push_back(double(c.spp)), e.push_back(c.error.rmse);
    r.time_fit = fit_loglog(t, e);
    r.spp_fit = fit_loglog(s, e);
    if (cps.empty()) return r;

    // Spread of log RMSE from P effective pixels (channels taken as correlated, tails allowed):
    // sd(log RMSE) ~ 1/sqrt(P); the fitted slope spreads over the log range of samples.
    const double sigma_log = 1.0 / std::sqrt(std::max(1.0, pixels));
    const double range = std::log(s.back() / s.front());
    r.slope_sigma = range > 0 ? std::sqrt(2.0) * sigma_log / range : 1.0;

    // Local slope over the last three checkpoints; flat means bias (or the reference's noise).
    const size_t k = std::min<size_t>(3, cps.size());
    const std::vector<double> ls(s.end() - long(k), s.end()), le(e.end() - long(k), e.end());
    r.local_slope = fit_loglog(ls, le).slope;
    const double local_range = std::log(ls.back() / ls.front());
    const double local_sigma = local_range > 0 ? std::sqrt(2.0) * sigma_log / local_range : 1.0;
    const Checkpoint& last = cps.back();
    r.noise_floor = 3 * last.error.reference_noise;
    r.estimated_bias = last.error.mean_signed_error;
    r.relative_bias = reference_mean != 0 ? r.estimated_bias / reference_mean : 0;
    r.biased = cps.size() >= 3 && local_range > 0 &&
               r.local_slope > std::max(-0.25, -0.5 + 4 * local_sigma) &&
               last.error.rmse > r.noise_floor;
    return r;
}

std::string TimeToError::text() const {
    char buf[96];
    if (reached && before_first)
        std::snprintf(buf, sizeof buf, "<= %.3g s", seconds);
    else if (reached)
        std::snprintf(buf, sizeof buf, "%.3g s", seconds);
    else if (extrapolated)
        std::snprintf(buf, sizeof buf, "~%.3g s (extrapolated)", seconds);
    else
        std::snprintf(buf, sizeof buf, "never (biased)");
    return buf;
}

TimeToError time_to_error(const std::vector<Checkpoint>& cps, double target,
                          const ConvergenceReport& report) {
    TimeToError r;
    if (cps.empty()) return r;
    // Reached: interpolate log time linearly in log error between the bracketing checkpoints.
    for (size_t i = 0; i < cps.size(); ++i) {
        const double e = cps[i].error.rel_rmse;
        if (e > target) continue;
        r.reached = true;
        if (i == 0) {
            r.before_first = true, r.seconds = cps[0].seconds;
            return r;
        }
        const double e0 = cps[i - 1].error.rel_rmse, t0 = cps[i - 1].seconds, t1 = cps[i].seconds;
        const double f = e0 > e ? std::log(e0 / target) / std::log(e0 / e) : 1.0;
        r.seconds = std::exp(std::log(t0) + f * std::log(t1 / t0));
        return r;
    }
    // Not reached: project along the ideal -1/2 rate unless the error stopped falling.
    const double e = cps.back().error.rel_rmse;
    if (report.biased && std::abs(report.relative_bias) >= target) return r;
    r.extrapolated = true;
    r.seconds = cps.back().seconds * (e / target) * (e / target);
    return r;
}

}  // namespace mcpt
