// What an error curve's result says, as files and tables: the CSV of every checkpoint, the
// log-log plot, the time-to-error table and the HTML report, the same for `mcpt converge`,
// the C API and Java.
#pragma once
#include <string>
#include <vector>

#include "common/analysis/converge_job.h"
#include "common/io/svg_plot.h"

namespace mcpt {

// backend,device,checkpoint,seconds,spp,rmse,rel_mse,mean_signed_error,reference_noise,rel_rmse
void write_converge_csv(const std::string& path, const ConvergeResult& result);
// RMSE against seconds, a curve per run, the ideal -1/2 slope and the reference's noise.
SvgPlot converge_plot(const ConvergeResult& result);
// A checkpoint's cells: seconds, spp, rmse, rel rmse, rel mse, mean signed.
std::vector<std::string> checkpoint_cells(const Checkpoint& c);
// The time to each target relative RMSE: a row per target, a column per run (xN against the
// first run).
std::vector<std::string> time_to_error_header(const ConvergeResult& result);
std::vector<std::vector<std::string>> time_to_error_rows(const ConvergeResult& result);
// Per pixel: mean over channels of |image - reference| / (mean reference + 0.01).
std::vector<float> relative_error_map(const std::vector<float>& image, const Reference& ref);
// The self-contained report DIR/index.html: plot, fits and bias, time to error, each run's
// checkpoints, final image and error map (the images need ConvergeSpec::keep_images).
void write_converge_report(const ConvergeResult& result, const std::string& dir);

}  // namespace mcpt
