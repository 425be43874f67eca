#include "common/io/html_report.h"

#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <system_error>

#include "common/error.h"
#include "common/io/atomic_file.h"
#include "common/io/image_io.h"

namespace mcpt {

namespace {

// The page's whole style: readable without scripts, images pixelated when scaled up.
constexpr const char* kStyle = R"(
body { font-family: sans-serif; margin: 2em; max-width: 80em; color: #222; }
h1 { font-size: 1.5em; }
h2 { font-size: 1.2em; margin-top: 1.6em; border-bottom: 1px solid #ddd; }
table { border-collapse: collapse; margin: 0.5em 0; }
th, td { border: 1px solid #ccc; padding: 0.2em 0.6em; text-align: left; }
th { background: #f2f2f2; }
td { font-variant-numeric: tabular-nums; }
.verdict { padding: 0.4em 0.8em; border-radius: 4px; font-size: 1.05em; }
.verdict.pass { background: #e3f5e1; border-left: 6px solid #2e8b2e; }
.verdict.fail { background: #fbe3e3; border-left: 6px solid #c62828; }
.images { display: flex; flex-wrap: wrap; gap: 1em; }
figure { margin: 0; max-width: 20em; }
figure img { image-rendering: pixelated; border: 1px solid #ccc; }
figcaption { font-size: 0.85em; color: #444; }
pre { background: #f6f6f6; padding: 0.6em; overflow-x: auto; }
)";

}  // namespace

std::string html_escape(const std::string& text) { return svg_escape(text); }

std::string base64_encode(const std::vector<unsigned char>& bytes) {
    // Three bytes to four characters; the last group padded with '='.
    static constexpr char alphabet[] =
        "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    std::string out;
    out.reserve((bytes.size() + 2) / 3 * 4);
    for (size_t i = 0; i < bytes.size(); i += 3) {
        const size_t n = std::min<size_t>(3, bytes.size() - i);
        uint32_t group = uint32_t(bytes[i]) << 16;
        if (n > 1) group |= uint32_t(bytes[i + 1]) << 8;
        if (n > 2) group |= uint32_t(bytes[i + 2]);
        for (size_t k = 0; k < 4; ++k) out += k <= n ? alphabet[(group >> (18 - 6 * k)) & 63] : '=';
    }
    return out;
}

HtmlReport::HtmlReport(std::string title) : title_(std::move(title)) {}

void HtmlReport::heading(const std::string& text, int level) {
    const std::string h = "h" + std::to_string(std::clamp(level, 2, 6));
    body_ += "<" + h + ">" + html_escape(text) + "</" + h + ">\n";
}

void HtmlReport::paragraph(const std::string& text) {
    body_ += "<p>" + html_escape(text) + "</p>\n";
}

void HtmlReport::verdict(const std::string& label, bool pass, const std::string& detail,
                         const std::string& id) {
    body_ += "<p class=\"verdict " + std::string(pass ? "pass" : "fail") + "\"";
    if (!id.empty()) body_ += " id=\"" + html_escape(id) + "\"";
    body_ += "><strong>" + html_escape(label) + "</strong>";
    if (!detail.empty()) body_ += ": " + html_escape(detail);
    body_ += "</p>\n";
}

void HtmlReport::table(const std::vector<std::string>& header,
                       const std::vector<std::vector<std::string>>& rows) {
    body_ += "<table>\n<tr>";
    for (const std::string& h : header) body_ += "<th>" + html_escape(h) + "</th>";
    body_ += "</tr>\n";
    for (const auto& row : rows) {
        body_ += "<tr>";
        for (const std::string& cell : row) body_ += "<td>" + html_escape(cell) + "</td>";
        body_ += "</tr>\n";
    }
    body_ += "</table>\n";
}

void HtmlReport::images(const std::vector<ReportImage>& row) {
    body_ += "<div class=\"images\">\n";
    for (const ReportImage& im : row) {
        // PNG bytes as a data URI, scaled up by a whole factor to at least 192 pixels wide.
        const std::string png = base64_encode(encode_png8(im.width, im.height, im.rgb8));
        const int scale = std::max(1, (192 + im.width - 1) / std::max(im.width, 1));
        body_ += "<figure><img src=\"data:image/png;base64," + png + "\" width=\"" +
                 std::to_string(im.width * scale) + "\" height=\"" +
                 std::to_string(im.height * scale) + "\" alt=\"" + html_escape(im.caption) +
                 "\"><figcaption>" + html_escape(im.caption) + "</figcaption></figure>\n";
    }
    body_ += "</div>\n";
}

void HtmlReport::plot(const SvgPlot& svg_plot) {
    // Inline SVG needs no namespace declaration in HTML (the parser supplies it), and the page
    // names no URL at all.
    std::string svg = render_svg(svg_plot);
    const std::string xmlns = " xmlns=\"http://www.w3.org/2000/svg\"";
    for (size_t at = svg.find(xmlns); at != std::string::npos; at = svg.find(xmlns, at))
        svg.erase(at, xmlns.size());
    body_ += "<div class=\"plot\">\n" + svg + "</div>\n";
}

void HtmlReport::pre(const std::string& text) {
    body_ += "<pre>" + html_escape(text) + "</pre>\n";
}

std::string HtmlReport::html() const {
    return "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n"
           "<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n<title>" +
           html_escape(title_) + "</title>\n<style>" + kStyle + "</style>\n</head>\n<body>\n<h1>" +
           html_escape(title_) + "</h1>\n" + body_ + "</body>\n</html>\n";
}

void prepare_report_dir(const std::string& dir) {
    // Created with its parents; then it must be a folder this process can write into.
    if (dir.empty()) throw Error("--report needs a folder name");
    std::error_code ec;
    std::filesystem::create_directories(dir, ec);
    if (ec) throw Error("cannot create the report folder '" + dir + "': " + ec.message());
    if (!std::filesystem::is_directory(dir, ec))
        throw Error("cannot write the report into '" + dir + "': not a folder");
    if (::access(dir.c_str(), W_OK | X_OK) != 0)
        throw Error("cannot write the report into '" + dir + "': the folder is not writable");
}

void HtmlReport::write(const std::string& dir) const {
    prepare_report_dir(dir);
    write_text_atomically((std::filesystem::path(dir) / "index.html").string(), html());
}

}  // namespace mcpt
