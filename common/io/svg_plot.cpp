#include "common/io/svg_plot.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <fstream>
#include <sstream>

#include "common/error.h"
#include "common/io/atomic_file.h"

namespace mcpt {

namespace {

const char* const kPalette[] = {"#1f77b4", "#d62728", "#2ca02c", "#ff7f0e", "#9467bd",
                                "#8c564b", "#e377c2", "#7f7f7f", "#bcbd22", "#17becf"};

std::string fmt(const char* f, double v) {
    char buf[64];
    std::snprintf(buf, sizeof buf, f, v);
    return buf;
}

// A log10 axis range covering the data, widened to at least one decade.
struct LogAxis {
    double lo = 0, hi = 1;  // log10 bounds
    void fit(double min_v, double max_v) {
        lo = std::log10(min_v), hi = std::log10(max_v);
        if (!(hi > lo)) lo -= 0.5, hi += 0.5;
        const double pad = 0.04 * (hi - lo);
        lo -= pad, hi += pad;
        if (hi - lo < 1) {
            const double mid = 0.5 * (lo + hi);
            lo = mid - 0.5, hi = mid + 0.5;
        }
    }
    double frac(double v) const { return (std::log10(v) - lo) / (hi - lo); }
    // Tick values inside the range: decades, plus 2 and 5 when decades are few.
    std::vector<std::pair<double, bool>> ticks() const {
        std::vector<std::pair<double, bool>> t;  // value, labelled
        const bool few = hi - lo < 2.5;
        for (int k = int(std::floor(lo)); k <= int(std::ceil(hi)); ++k) {
            for (int m = 1; m <= 9; ++m) {
                const double v = m * std::pow(10.0, k);
                const double l = std::log10(v);
                if (l < lo || l > hi) continue;
                t.push_back({v, m == 1 || (few && (m == 2 || m == 5))});
            }
        }
        return t;
    }
};

std::string tick_label(double v) {
    // 1e5 rather than 1e+05 for large and small decades.
    if (v < 1e5 && v >= 1e-3) return fmt("%g", v);
    const int e = int(std::floor(std::log10(v) + 1e-9));
    const double m = v / std::pow(10.0, e);
    return fmt("%g", std::round(m * 1e6) / 1e6) + "e" + std::to_string(e);
}

}  // namespace

std::string svg_escape(const std::string& text) {
    std::string out;
    for (char c : text) {
        switch (c) {
            case '&':
                out += "&amp;";
                break;
            case '<':
                out += "&lt;";
                break;
            case '>':
                out += "&gt;";
                break;
            case '"':
                out += "&quot;";
                break;
            case '\'':
                out += "&#39;";
                break;
            default:
                out += c;
        }
    }
    return out;
}

std::string render_svg(const SvgPlot& plot) {
    // Data range over every drawable point.
    double xmin = HUGE_VAL, xmax = -HUGE_VAL, ymin = HUGE_VAL, ymax = -HUGE_VAL;
    for (const SvgSeries& s : plot.series) {
        for (size_t i = 0; i < std::min(s.x.size(), s.y.size()); ++i) {
            if (!(s.x[i] > 0 && s.y[i] > 0 && std::isfinite(s.x[i]) && std::isfinite(s.y[i])))
                continue;
            xmin = std::min(xmin, s.x[i]), xmax = std::max(xmax, s.x[i]);
            ymin = std::min(ymin, s.y[i]), ymax = std::max(ymax, s.y[i]);
        }
    }
    if (xmin > xmax) xmin = ymin = 1, xmax = ymax = 10;
    LogAxis ax, ay;
    ax.fit(xmin, xmax), ay.fit(ymin, ymax);

    // Plot area.
    const double left = 80, right = 20, top = 40, bottom = 60;
    const double pw = plot.width - left - right, ph = plot.height - top - bottom;
    auto px = [&](double x) { return left + pw * ax.frac(x); };
    auto py = [&](double y) { return top + ph * (1 - ay.frac(y)); };

    std::ostringstream o;
    o << "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"" << plot.width << "\" height=\""
      << plot.height << "\" font-family=\"sans-serif\" font-size=\"12\">\n";
    o << "<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n";
    o << "<text x=\"" << plot.width / 2 << "\" y=\"22\" text-anchor=\"middle\" font-size=\"15\">"
      << svg_escape(plot.title) << "</text>\n";

    // Grid and tick labels.
    for (const auto& [v, labelled] : ax.ticks()) {
        const double x = px(v);
        o << "<line x1=\"" << fmt("%.2f", x) << "\" y1=\"" << top << "\" x2=\"" << fmt("%.2f", x)
          << "\" y2=\"" << top + ph << "\" stroke=\"" << (labelled ? "#ccc" : "#eee") << "\"/>\n";
        if (labelled)
            o << "<text x=\"" << fmt("%.2f", x) << "\" y=\"" << top + ph + 16
              << "\" text-anchor=\"middle\">" << tick_label(v) << "</text>\n";
    }
    for (const auto& [v, labelled] : ay.ticks()) {
        const double y = py(v);
        o << "<line x1=\"" << left << "\" y1=\"" << fmt("%.2f", y) << "\" x2=\"" << left + pw
          << "\" y2=\"" << fmt("%.2f", y) << "\" stroke=\"" << (labelled ? "#ccc" : "#eee")
          << "\"/>\n";
        if (labelled)
            o << "<text x=\"" << left - 6 << "\" y=\"" << fmt("%.2f", y + 4)
              << "\" text-anchor=\"end\">" << tick_label(v) << "</text>\n";
    }
    o << "<rect x=\"" << left << "\" y=\"" << top << "\" width=\"" << pw << "\" height=\"" << ph
      << "\" fill=\"none\" stroke=\"black\"/>\n";
    o << "<text x=\"" << left + pw / 2 << "\" y=\"" << plot.height - 14
      << "\" text-anchor=\"middle\">" << svg_escape(plot.x_label) << "</text>\n";
    o << "<text transform=\"translate(18," << top + ph / 2
      << ") rotate(-90)\" text-anchor=\"middle\">" << svg_escape(plot.y_label) << "</text>\n";

    // Series, clipped to the plot area.
    o << "<clipPath id=\"area\"><rect x=\"" << left << "\" y=\"" << top << "\" width=\"" << pw
      << "\" height=\"" << ph << "\"/></clipPath>\n<g clip-path=\"url(#area)\">\n";
    std::vector<std::string> colors;
    for (size_t k = 0; k < plot.series.size(); ++k) {
        const SvgSeries& s = plot.series[k];
        const std::string color = s.color.empty() ? kPalette[k % 10] : s.color;
        colors.push_back(color);
        std::string points;
        for (size_t i = 0; i < std::min(s.x.size(), s.y.size()); ++i) {
            if (!(s.x[i] > 0 && s.y[i] > 0 && std::isfinite(s.x[i]) && std::isfinite(s.y[i])))
                continue;
            points += fmt("%.2f,", px(s.x[i])) + fmt("%.2f ", py(s.y[i]));
            if (s.markers)
                o << "<circle cx=\"" << fmt("%.2f", px(s.x[i])) << "\" cy=\""
                  << fmt("%.2f", py(s.y[i])) << "\" r=\"3\" fill=\"" << color << "\"/>\n";
        }
        o << "<polyline fill=\"none\" stroke=\"" << color << "\" stroke-width=\"1.8\""
          << (s.dashed ? " stroke-dasharray=\"6,4\"" : "") << " points=\"" << points << "\"/>\n";
    }
    o << "</g>\n";

    // Legend, in the corner of the plot that the curves cross least.
    size_t longest = 0;
    for (const SvgSeries& s : plot.series) longest = std::max(longest, s.label.size());
    const double lw = 40 + 6.8 * double(longest), lh = 18.0 * double(plot.series.size()) + 8;
    double lx = left + pw - lw - 8, ly = top + 8;
    size_t best = SIZE_MAX;
    for (int corner = 0; corner < 4; ++corner) {
        const double cx = corner % 2 ? left + 8 : left + pw - lw - 8;
        const double cy = corner / 2 ? top + ph - lh - 8 : top + 8;
        size_t covered = 0;
        for (const SvgSeries& s : plot.series) {
            // Points along each segment, in plot coordinates.
            for (size_t i = 0; i + 1 < std::min(s.x.size(), s.y.size()); ++i) {
                if (!(s.x[i] > 0 && s.y[i] > 0 && s.x[i + 1] > 0 && s.y[i + 1] > 0)) continue;
                for (int k = 0; k <= 16; ++k) {
                    const double f = k / 16.0;
                    const double x = px(s.x[i]) * (1 - f) + px(s.x[i + 1]) * f;
                    const double y = py(s.y[i]) * (1 - f) + py(s.y[i + 1]) * f;
                    covered += x >= cx && x <= cx + lw && y >= cy && y <= cy + lh;
                }
            }
        }
        if (covered < best) best = covered, lx = cx, ly = cy;
    }
    if (!plot.series.empty())
        o << "<rect x=\"" << lx << "\" y=\"" << ly << "\" width=\"" << lw << "\" height=\"" << lh
          << "\" fill=\"white\" fill-opacity=\"0.9\" stroke=\"#999\"/>\n";
    for (size_t k = 0; k < plot.series.size(); ++k) {
        const double y = ly + 16 + 18.0 * double(k);
        o << "<line x1=\"" << lx + 6 << "\" y1=\"" << y - 4 << "\" x2=\"" << lx + 30 << "\" y2=\""
          << y - 4 << "\" stroke=\"" << colors[k] << "\" stroke-width=\"2\""
          << (plot.series[k].dashed ? " stroke-dasharray=\"6,4\"" : "") << "/>\n";
        o << "<text x=\"" << lx + 36 << "\" y=\"" << y << "\">" << svg_escape(plot.series[k].label)
          << "</text>\n";
    }
    o << "</svg>\n";
    return o.str();
}

void write_svg(const std::string& path, const SvgPlot& plot) {
    write_text_atomically(path, render_svg(plot));
}

}  // namespace mcpt
