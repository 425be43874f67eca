// Renders split over runs that share nothing (Slurm job arrays, Kubernetes Indexed Jobs): run
// I of N renders its share of the sample range into a checkpoint (render --part I/N), and
// merge_parts() adds the checkpoints into one image; in reproducible mode (exact sums) it is
// the image of one render of every sample, bit for bit.
#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include "common/render/render_loop.h"
#include "common/render/session.h"

namespace mcpt {

// Part `index` (from 0) of `count` of a job of `job_spp` samples per pixel: boundaries at
// multiples of `granule` (kReproducibleGroupSpp when reproducible; job_spp must be one).
SamplePart part_range(uint64_t job_spp, uint32_t index, uint32_t count, uint32_t granule);

// "I/N", part I of N counted from 1 ("2/4" -> index 1, count 4; a 0-based array index i is
// part i+1). Throws mcpt::Error.
void parse_part(const std::string& text, uint32_t& index, uint32_t& count);

struct MergeResult {
    RenderResult sums;                 // every part's samples, added
    uint64_t job_spp = 0;              // the samples the job asked for
    uint64_t missing_spp = 0;          // samples per pixel no part holds
    std::vector<std::string> devices;  // the devices the parts were rendered on
    std::string report;                // one line per part, then the gaps
};

// Reads the part checkpoints, checks they belong to one job (the same fingerprint but for
// the device, the same job size) and cover disjoint sample ranges, and adds them. Throws
// mcpt::Error naming the file and the reason: another job, overlapping ranges, not a part, or
// samples missing (unless allow_missing: then missing_spp says how many).
MergeResult merge_parts(const std::vector<std::string>& paths, bool allow_missing);

}  // namespace mcpt
