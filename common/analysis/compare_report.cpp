#include "common/analysis/compare_report.h"

#include <cstdio>

#include "common/io/false_color.h"
#include "common/io/html_report.h"

namespace mcpt {

namespace {

std::string number(const char* format, double x) {
    char b[64];
    std::snprintf(b, sizeof b, format, x);
    return b;
}

}  // namespace

std::vector<SpeedRow> compare_speed_rows(const CompareResult& r) {
    const CompareSideResult(&s)[2] = r.sides;
    std::vector<SpeedRow> rows;
    rows.push_back({"backend", s[0].description, s[1].description});
    // Several devices: how many batches each rendered (a device ready late renders fewer).
    const auto device_count = [](const CompareSideResult& side) {
        std::string d = std::to_string(side.devices);
        const std::vector<int>& per = side.batches.per_device;
        if (per.size() > 1) {
            d += " (batches";
            for (size_t k = 0; k < per.size(); ++k) d += (k ? "+" : " ") + std::to_string(per[k]);
            d += ")";
        }
        return d;
    };
    rows.push_back({"devices", device_count(s[0]), device_count(s[1])});
    const auto row = [&](const char* name, double x, double y) {
        rows.push_back({name, std::to_string(x), std::to_string(y)});
    };
    rows.push_back({"k-d tree", s[0].tree, s[1].tree});
    row("compile/pipeline (s)", s[0].compile_seconds, s[1].compile_seconds);
    const auto per_sample = [](const CompareSideResult& side) {
        const double rate = side.samples_per_second();
        return rate > 0 ? 1e9 / rate : 0;
    };
    row("time per sample (ns)", per_sample(s[0]), per_sample(s[1]));
    row("M samples/s", s[0].samples_per_second() * 1e-6, s[1].samples_per_second() * 1e-6);
    row("M rays/s", s[0].rays_per_second() * 1e-6, s[1].rays_per_second() * 1e-6);
    // Where the time goes: in the kernel (device timers) or around it (submission, waits,
    // read-back): a slower side with the same device time pays in host overhead.
    row("device time/sample (ns)", s[0].device_ns_per_sample(), s[1].device_ns_per_sample());
    row("host overhead (%)", 100 * s[0].host_overhead(), 100 * s[1].host_overhead());
    return rows;
}

std::string compare_speed_ratio(const CompareResult& r) {
    std::string line = number("speed ratio B/A: %.3f", r.speed_ratio());
    const double a = r.sides[0].device_ns_per_sample(), b = r.sides[1].device_ns_per_sample();
    if (a > 0 && b > 0) line += number(" (device time alone: %.3f)", a / b);
    return line;
}

std::string same_seed_line(const CompareResult& r) {
    char line[320];
    if (!r.has_same_seed) {
        std::snprintf(line, sizeof line, "same seed (%llu spp): not rendered (cancelled)",
                      (unsigned long long)r.same_seed_spp);
        return line;
    }
    const SameSeedDiff& d = r.maps.same_seed;
    std::snprintf(line, sizeof line,
                  "same seed (%llu spp): %s: %zu of %zu pixels diverged (> %.0e relative), %.3f%% "
                  "(limit %.3g%%); max |difference| %.3g",
                  (unsigned long long)r.same_seed_spp, r.same_seed_agrees ? "AGREE" : "DIFFER",
                  d.diverged, d.pixels, d.tolerance, 100 * d.fraction_diverged(),
                  100 * r.same_seed_limit, d.max_abs_diff);
    return line;
}

std::vector<float> compare_test_map(const CompareResult& r) {
    const size_t pixels = size_t(r.width) * size_t(r.height);
    std::vector<float> img(3 * pixels, 0.f);
    if (!r.has_agreement) return img;
    const Agreement& a = r.agreement;
    for (size_t i = 0; i < pixels && i < a.p_image.size(); ++i) {
        img[3 * i] = a.p_image[i];
        img[3 * i + 1] = a.z_image[i];
        img[3 * i + 2] = float(r.sides[1].batches.mean[i] - r.sides[0].batches.mean[i]);
    }
    return img;
}

void write_compare_report(const CompareResult& r, const std::string& scene,
                          const std::string& dir) {
    const bool agree = r.agree();
    const bool statistical = r.has_agreement && r.agreement.agree;
    const int w = r.width, h = r.height;
    HtmlReport html("mcpt compare " + scene + ": " + (agree ? "AGREE" : "DIFFER"));
    // The overall verdict first, as the exit status has it.
    html.verdict(agree ? "AGREE" : "DIFFER", agree,
                 std::string("statistical test ") + (statistical ? "AGREE" : "DIFFER") +
                     ", same-seed test " + (r.same_seed_agrees ? "AGREE" : "DIFFER") +
                     (r.cancelled ? " (cancelled: a test that did not run differs)" : "") +
                     " (exit status " + (agree ? "0" : "2") + ")",
                 "overall");
    char line[256];
    std::snprintf(line, sizeof line,
                  "Scene %s, %dx%d, %d batches x %llu spp per backend, same seed at %llu spp.",
                  scene.c_str(), w, h, r.batches, (unsigned long long)r.spp,
                  (unsigned long long)r.same_seed_spp);
    html.paragraph(line);

    // Speed, the rows the command prints.
    html.heading("Speed");
    std::vector<std::vector<std::string>> rows;
    for (const SpeedRow& s : compare_speed_rows(r)) rows.push_back({s[0], s[1], s[2]});
    html.table({"", "A", "B"}, rows);
    html.paragraph(compare_speed_ratio(r) + (r.parallel ? " (A and B rendered at once)" : ""));

    // Statistical test: verdict, its numbers, the z map.
    html.heading("Statistical agreement (independent seeds)");
    if (r.has_agreement) {
        const Agreement& a = r.agreement;
        const std::string v = a.verdict();
        html.verdict(a.agree ? "AGREE" : "DIFFER", a.agree, v.substr(v.find(": ") + 2));
        html.table(
            {"measure", "value"},
            {{"family-wise alpha", number("%.3g", r.alpha)},
             {"pixels tested", std::to_string(a.pixels_tested)},
             {"mean radiance B vs A", number("%+.3f%%", 100 * a.mean_relative_diff)},
             {"min p (Sidak level)",
              number("%.3g", a.min_p) + " (" + number("%.3g", a.sidak_level) + ")"},
             {"pixels below the Sidak level", std::to_string(a.sidak_rejections)},
             {"Benjamini-Hochberg discoveries", std::to_string(a.bh_discoveries)},
             {"mean z score (limit +-" + number("%.3g", a.global_z_limit) + ")",
              number("%.3f", a.mean_z_score)},
             {"chi2 z score (limit " + number("%.3g", a.global_z_limit) + ")",
              number("%.3f", a.chi2_score)},
             {"uniform bias detected with 90% power", number("%.3g%%", 100 * a.detectable_bias)},
             {"non-finite samples A, B", std::to_string(r.sides[0].batches.nonfinite) + ", " +
                                             std::to_string(r.sides[1].batches.nonfinite)}});
        html.images({{w, h, false_color_pixels(a.z_image, z_color),
                      "Per-pixel Welch z of B - A over the batch means: white 0, red B brighter, "
                      "blue B darker, full colour at |z| >= 5; magenta not finite"}});
    } else {
        html.verdict("NOT RUN", false, "cancelled before two batches a side");
    }

    // Same seed: verdict, both images, the relative difference and its z.
    html.heading("Same seed");
    const std::string same = same_seed_line(r);
    html.verdict(r.same_seed_agrees ? "AGREE" : "DIFFER", r.same_seed_agrees,
                 same.substr(same.find(": ") + 2));
    if (r.has_same_seed) {
        const SameSeedDiff& d = r.maps.same_seed;
        // The relative map log-scaled: 1e-4 x tolerance (black) to 100 x tolerance (white-ish).
        const float lo = float(d.tolerance * 1e-4), hi = float(d.tolerance * 1e2);
        // Both images at A's exposure, so that a brighter B looks brighter.
        const float exposure = display_exposure(r.sides[0].same_seed.mean_radiance());
        const std::string shown = number(" (sRGB, exposure %.3g)", exposure);
        std::snprintf(line, sizeof line,
                      "Relative difference max over channels |B - A| / max(|A|, |B|, 1e-3), log "
                      "scale: black <= %.0e, the tolerance %.0e at 2/3, white >= %.0e",
                      lo, d.tolerance, hi);
        html.images(
            {{w, h, radiance_to_srgb8(r.sides[0].same_seed.mean_image(), exposure),
              "A: " + r.sides[0].first_device + shown},
             {w, h, radiance_to_srgb8(r.sides[1].same_seed.mean_image(), exposure),
              "B: " + r.sides[1].first_device + shown},
             {w, h,
              false_color_pixels(r.maps.relative,
                                 [&](float x) { return sequential_color(log_unit(x, lo, hi)); }),
              line},
             {w, h, false_color_pixels(r.maps.z, z_color),
              "z of B - A from each side's sample standard error (conservative with shared "
              "samples): white 0, red B brighter, blue B darker, full colour at |z| >= 5"}});
    }
    html.write(dir);
}

}  // namespace mcpt
