#include "common/analysis/converge_report.h"

#include <cmath>
#include <cstdio>
#include <sstream>

#include "common/io/atomic_file.h"
#include "common/io/false_color.h"
#include "common/io/html_report.h"

namespace mcpt {

void write_converge_csv(const std::string& path, const ConvergeResult& result) {
    const std::vector<ConvergeRun>& runs = result.runs;
    std::ostringstream f;  // written whole at the end (atomic_file.h)
    f << "backend,device,checkpoint,seconds,spp,rmse,rel_mse,mean_signed_error,reference_noise,"
         "rel_rmse\n";
    for (const ConvergeRun& r : runs) {
        for (size_t k = 0; k < r.checkpoints.size(); ++k) {
            const Checkpoint& c = r.checkpoints[k];
            char line[512];
            std::snprintf(line, sizeof line, "%s,\"%s\",%zu,%.6f,%llu,%.8g,%.8g,%.8g,%.8g,%.8g\n",
                          r.backend.c_str(), r.device.c_str(), k, c.seconds,
                          (unsigned long long)c.spp, c.error.rmse, c.error.rel_mse,
                          c.error.mean_signed_error, c.error.reference_noise, c.error.rel_rmse);
            f << line;
        }
    }
    write_text_atomically(path, f.str());
}

SvgPlot converge_plot(const ConvergeResult& result) {
    const std::string& scene = result.label;
    const std::vector<ConvergeRun>& runs = result.runs;
    SvgPlot plot;
    plot.title = "RMSE against render time: " + scene;
    plot.x_label = "seconds";
    plot.y_label = "RMSE";
    double t_min = HUGE_VAL, t_max = 0;
    for (const ConvergeRun& r : runs) {
        // One curve per backend, its fitted slope in the legend.
        SvgSeries s;
        char label[160];
        std::snprintf(label, sizeof label, "%s: %.40s (slope %.3f)", r.backend.c_str(),
                      r.device.c_str(), r.report.time_fit.slope);
        s.label = label;
        for (const Checkpoint& c : r.checkpoints) {
            s.x.push_back(c.seconds), s.y.push_back(c.error.rmse);
            if (c.seconds > 0)
                t_min = std::min(t_min, c.seconds), t_max = std::max(t_max, c.seconds);
        }
        plot.series.push_back(s);
    }
    if (!runs.empty() && !runs[0].checkpoints.empty() && t_max > t_min) {
        // The ideal -1/2 line through the first backend's last checkpoint; the reference noise.
        const Checkpoint& last = runs[0].checkpoints.back();
        SvgSeries ideal;
        ideal.label = "ideal slope -1/2";
        ideal.color = "#888888", ideal.dashed = true, ideal.markers = false;
        for (double t : {t_min, t_max})
            ideal.x.push_back(t), ideal.y.push_back(last.error.rmse * std::sqrt(last.seconds / t));
        plot.series.push_back(ideal);
        if (last.error.reference_noise > 0) {
            SvgSeries floor;
            floor.label = "reference noise (subtracted)";
            floor.color = "#bbbbbb", floor.dashed = true, floor.markers = false;
            floor.x = {t_min, t_max};
            floor.y = {last.error.reference_noise, last.error.reference_noise};
            plot.series.push_back(floor);
        }
    }
    return plot;
}

std::vector<std::string> checkpoint_cells(const Checkpoint& c) {
    char b[4][48];
    std::snprintf(b[0], sizeof b[0], "%.3f", c.seconds);
    std::snprintf(b[1], sizeof b[1], "%.4g", c.error.rmse);
    std::snprintf(b[2], sizeof b[2], "%.2f%%", 100 * c.error.rel_rmse);
    std::snprintf(b[3], sizeof b[3], "%.4g", c.error.rel_mse);
    char signed_error[48];
    std::snprintf(signed_error, sizeof signed_error, "%+.4g", c.error.mean_signed_error);
    return {b[0], std::to_string(c.spp), b[1], b[2], b[3], signed_error};
}

std::vector<std::string> time_to_error_header(const ConvergeResult& result) {
    std::vector<std::string> header{"rel. RMSE"};
    for (const ConvergeRun& r : result.runs) header.push_back(r.backend + ": " + r.device);
    return header;
}

std::vector<std::vector<std::string>> time_to_error_rows(const ConvergeResult& result) {
    std::vector<std::vector<std::string>> rows;
    for (size_t t = 0; t < result.targets.size(); ++t) {
        char head[32];
        std::snprintf(head, sizeof head, "%.3g%%", 100 * result.targets[t]);
        rows.push_back({head});
        double first = 0;
        for (size_t i = 0; i < result.runs.size(); ++i) {
            const TimeToError& tte = result.runs[i].time_to_target[t];
            std::string cell = tte.text();
            if (i == 0)
                first = tte.seconds;
            else if (first > 0 && tte.seconds > 0) {
                char ratio[48];
                std::snprintf(ratio, sizeof ratio, " (x%.2f)", tte.seconds / first);
                cell += ratio;
            }
            rows.back().push_back(cell);
        }
    }
    return rows;
}

// Per pixel: mean over channels of |image - reference| / (mean reference + 0.01).
std::vector<float> relative_error_map(const std::vector<float>& image, const Reference& ref) {
    std::vector<float> map(image.size() / 3);
    for (size_t i = 0; i < map.size(); ++i) {
        double diff = 0, value = 0;
        for (int c = 0; c < 3; ++c)
            diff += std::abs(image[3 * i + c] - ref.mean[3 * i + c]), value += ref.mean[3 * i + c];
        map[i] = float(diff / (value + 0.03));
    }
    return map;
}

void write_converge_report(const ConvergeResult& result, const std::string& dir) {
    const std::vector<ConvergeRun>& runs = result.runs;
    const Reference& ref = result.reference;
    const std::string& label = result.label;
    const bool biased = result.biased();
    HtmlReport h("mcpt converge " + label + ": " + (biased ? "BIASED" : "CONSISTENT"));
    h.verdict(biased ? "BIASED" : "CONSISTENT", !biased,
              biased ? "a run flattens above the noise floor"
                     : "every run converges at its expected rate",
              "overall");
    h.paragraph(result.settings);
    h.paragraph("Reference: " + ref.source);
    h.plot(converge_plot(result));

    // Fits and bias, one line per run.
    h.heading("Fits and bias");
    for (const ConvergeRun& r : runs) {
        char fit[160];
        std::snprintf(fit, sizeof fit, "RMSE ~ time^%.3f, ~ spp^%.3f; ", r.report.time_fit.slope,
                      r.report.spp_fit.slope);
        h.verdict(r.backend + " " + r.device, !r.report.biased, fit + r.report.verdict());
    }
    // Time to a relative RMSE.
    h.heading("Time to a relative RMSE");
    h.table(time_to_error_header(result), time_to_error_rows(result));
    if (runs.size() > 1) h.paragraph("xN: time relative to " + runs[0].backend);

    // Per run: its checkpoints, final image and error map.
    constexpr float lo = 1e-4f, hi = 1.f;
    const float exposure = display_exposure(ref.mean_value());
    char shown[64];
    std::snprintf(shown, sizeof shown, " spp (sRGB, exposure %.3g)", exposure);
    for (const ConvergeRun& r : runs) {
        h.heading(r.backend + ": " + r.device);
        std::vector<std::vector<std::string>> rows;
        for (const Checkpoint& c : r.checkpoints) rows.push_back(checkpoint_cells(c));
        h.table({"seconds", "spp", "rmse", "rel rmse", "rel mse", "mean signed"}, rows);
        if (r.image.empty()) continue;  // not kept
        const uint64_t spp = r.checkpoints.empty() ? 0 : r.checkpoints.back().spp;
        h.images(
            {{result.width, result.height, radiance_to_srgb8(r.image, exposure),
              "Final image, " + std::to_string(spp) + shown},
             {result.width, result.height,
              false_color_pixels(relative_error_map(r.image, ref),
                                 [&](float x) { return sequential_color(log_unit(x, lo, hi)); }),
              "Per-pixel relative error mean |image - reference| / (mean reference + 0.01), "
              "log scale: black <= 1e-4, white >= 1"}});
    }
    h.write(dir);
}

}  // namespace mcpt
