// mcpt merge: the parts of a render split over runs that share nothing (render --part I/N)
// added into one image; in reproducible mode the image of one render of all samples.
#include <cstdio>
#include <memory>

#include "app/commands.h"
#include "common/error.h"
#include "common/io/image_io.h"
#include "common/render/parts.h"

namespace mcpt {

void run_merge(const MergeArgs& a) {
    check_image_path(a.output);
    const MergeResult m = merge_parts(a.parts, a.allow_missing);
    std::printf("merged %zu parts of a %llu spp job:\n%s", a.parts.size(),
                (unsigned long long)m.job_spp, m.report.c_str());
    if (m.missing_spp > 0)
        std::printf("WARNING: %llu of %llu samples per pixel missing: the image holds %llu\n",
                    (unsigned long long)m.missing_spp, (unsigned long long)m.job_spp,
                    (unsigned long long)m.sums.spp);
    if (m.devices.size() > 1) {
        std::printf(
            "parts rendered on %zu devices (a reproducible image is bit for bit one "
            "device's only when they are of one kind):\n",
            m.devices.size());
        for (const std::string& d : m.devices) std::printf("  %s\n", d.c_str());
    }
    const RenderResult& r = m.sums;
    std::printf("%dx%d, %llu spp, relative error %.2f%%, %llu non-finite samples\n", r.width,
                r.height, (unsigned long long)r.spp, 100 * r.relative_error(),
                (unsigned long long)r.nonfinite_total);
    write_image(a.output, r.width, r.height, r.mean_image());
    std::printf("wrote %s\n", a.output.c_str());
}
}  // namespace mcpt
