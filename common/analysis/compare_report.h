// What an A/B test's result says, as text, tables, images and an HTML report: the same
// words for `mcpt compare`, the C API and Java.
#pragma once
#include <array>
#include <string>
#include <vector>

#include "common/analysis/compare_job.h"

namespace mcpt {

using SpeedRow = std::array<std::string, 3>;  // name, A, B

// The speed table, side by side: backend, devices, tree, compile, time per sample, rates,
// device time and host overhead.
std::vector<SpeedRow> compare_speed_rows(const CompareResult& r);
// "speed ratio B/A: 0.812 (device time alone: 0.790)".
std::string compare_speed_ratio(const CompareResult& r);
// "same seed (4 spp): AGREE: 3 of 4096 pixels diverged ...".
std::string same_seed_line(const CompareResult& r);

// The per-pixel maps of a result, 3 floats per pixel: R the statistical test's p-value, G its
// signed z of B - A, B the difference of the batch means (zeros where the test did not run).
std::vector<float> compare_test_map(const CompareResult& r);

// The self-contained report DIR/index.html: verdicts, speed, maps, same-seed images.
void write_compare_report(const CompareResult& r, const std::string& scene, const std::string& dir);

}  // namespace mcpt
