// Adaptive sampling: how many samples each pixel takes next. The image's squared error is
// the sum over pixels of sigma_i^2 / n_i; doubling pixel i's count removes sigma_i^2 / (2 n_i)
// of it for n_i more samples, so each pass doubles the pixels that remove the most per sample,
// sigma_i^2 / n_i^2, within its budget. Counts only double (16, 32, 64, ...): the Sobol points
// of a pixel stay whole nets, whose stratification a count of 37 would partly lose (counts in
// proportion to sigma, rounded anywhere, were no faster than uniform sampling with Sobol).
//
// Unbiased by construction: a pixel's count never depends on its own samples. If it did, a
// pixel whose samples happened to miss a rare bright path would look quiet, get fewer samples
// and stay dark (2% low on the Cornell box at 32 spp in a first version that estimated sigma
// over the pixel's own 3x3 neighbourhood; still 0.8% low when the estimate left the pixel out
// but used all of its neighbours' samples, whose counts depended on the pixel in turn). So
// sigma_i comes from the warm-up alone (kAdaptiveWarmupSpp samples of every pixel, a count
// fixed in advance) of the pixel's neighbours, never of the pixel itself: its count is a
// function of samples independent of its own, and each of its samples keeps its expectation.
//
// sigma is the error of the warm-up, not its sample variance: with stratified (Sobol) samples
// a pixel whose radiance varies smoothly (the light's edge, direct light) has a large sample
// variance and almost no error. The difference of the means of the warm-up's two halves (two
// whole nets) measures what more samples would remove. One pixel's warm-up is too noisy to
// go by (a single bright sample decides it), so sigma_i pools the neighbours within
// kAdaptiveRadius pixels (with 1 pixel, the counts followed the warm-up's fireflies and
// rendering was 1.4 times slower than uniform sampling to the same error).
#pragma once
#include <cstdint>
#include <vector>

#include "common/render/render_loop.h"

namespace mcpt {

// sigma_i for every pixel, in arbitrary units (only ratios matter): the root of the mean,
// over the pixel's neighbours within kAdaptiveRadius and the channels, of (mean of the warm-up's
// first half - mean of its second half)^2. `first_half` holds the sums of the first half of the
// warm-up, `warm_up` those of all of it.
// With `own_noise` (a negative control for the tests), the pixel's own difference instead:
// its count then follows its own samples, and its mean is biased.
std::vector<double> adaptive_sigma(const RenderResult& first_half, const RenderResult& warm_up,
                                   bool own_noise = false);

// Samples per pixel for the next pass, at most `budget` in all (or one pixel's step): each
// pixel takes a step of its count so far (`counts`) again, at most `max_step` (a power of two:
// counts past it grow by whole nets of max_step), or nothing. The pixels under kAdaptiveFloor
// times the mean count after the pass step first, then those whose step removes the most
// squared error per sample (sigma_i^2 / n_i^2 for a doubling).
std::vector<uint32_t> plan_samples(const std::vector<double>& sigma,
                                   const std::vector<double>& counts, uint64_t budget,
                                   uint32_t max_step);

// sigma_i pools the neighbours within this many pixels (a square, the pixel left out).
constexpr int kAdaptiveRadius = 6;

// The least share of the mean count any pixel keeps (a pixel whose neighbours looked quiet
// in the warm-up still converges).
constexpr double kAdaptiveFloor = 0.125;

}  // namespace mcpt
