// A self-contained HTML report for CI (`compare --report DIR`, `converge --report DIR`): one
// file DIR/index.html with its CSS inline, every image embedded as a data:image/png;base64 URI
// and every plot as inline SVG; no script and no external URL, so the folder can be published
// as it is and read without JavaScript. All text given to it is escaped.
#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include "common/io/svg_plot.h"

namespace mcpt {

// One image of a row: 8-bit RGB pixels (3 bytes per pixel, top row first) and a caption.
struct ReportImage {
    int width = 0, height = 0;
    std::vector<uint8_t> rgb8;
    std::string caption;
};

class HtmlReport {
  public:
    explicit HtmlReport(std::string title);

    void heading(const std::string& text, int level = 2);  // <h2> by default (h1 is the title)
    void paragraph(const std::string& text);
    // A coloured line: "LABEL: detail", green when `pass`, red otherwise; `id` (optional) names
    // it, e.g. "overall" for the verdict a reader (or a test) looks for first.
    void verdict(const std::string& label, bool pass, const std::string& detail,
                 const std::string& id = "");
    void table(const std::vector<std::string>& header,
               const std::vector<std::vector<std::string>>& rows);
    // Images side by side (PNG, base64), each shown at least 192 pixels wide, pixelated.
    void images(const std::vector<ReportImage>& row);
    void plot(const SvgPlot& plot);  // render_svg() inline
    void pre(const std::string& text);

    // The whole page.
    std::string html() const;
    // Creates `dir` if needed and writes dir/index.html atomically; throws mcpt::Error.
    void write(const std::string& dir) const;

  private:
    std::string title_;
    std::string body_;
};

// Creates `dir` (and its parents) if needed; throws mcpt::Error unless it then is a writable
// folder: what a command checks before it renders.
void prepare_report_dir(const std::string& dir);

// &, <, >, ", ' as HTML entities (svg_escape()).
std::string html_escape(const std::string& text);
// Standard base64 (RFC 4648, with '=' padding).
std::string base64_encode(const std::vector<unsigned char>& bytes);

}  // namespace mcpt
