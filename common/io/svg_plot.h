// Log-log line plots written as standalone SVG, for convergence curves and benchmark scaling:
// axes with decade ticks and grid, one polyline per series, a legend. No plotting library.
#pragma once
#include <string>
#include <vector>

namespace mcpt {

struct SvgSeries {
    std::string label;
    std::vector<double> x, y;  // points with x, y > 0 are drawn; others are skipped
    std::string color;         // "" = from the palette
    bool dashed = false;
    bool markers = true;
};

struct SvgPlot {
    std::string title, x_label, y_label;
    std::vector<SvgSeries> series;
    int width = 720, height = 480;
};

// The plot as an SVG document (log scale on both axes).
std::string render_svg(const SvgPlot& plot);

// render_svg() into `path`; throws mcpt::Error if it cannot be written.
void write_svg(const std::string& path, const SvgPlot& plot);

// Escapes &, <, >, ", ' for SVG and HTML text.
std::string svg_escape(const std::string& text);

}  // namespace mcpt
