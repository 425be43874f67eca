#include "common/render/parts.h"

#include <algorithm>
#include <cstdio>

#include "common/error.h"
#include "common/render/checkpoint.h"

namespace mcpt {

SamplePart part_range(uint64_t job_spp, uint32_t index, uint32_t count, uint32_t granule) {
    granule = std::max(1u, granule);
    if (count == 0 || index >= count) throw Error("a part is numbered 1 to the number of parts");
    if (job_spp == 0) throw Error("a render in parts needs --spp (the samples of the whole job)");
    if (job_spp % granule != 0)
        throw Error("a reproducible render in parts takes a multiple of " +
                    std::to_string(granule) + " samples per pixel, not " + std::to_string(job_spp));
    const uint64_t groups = job_spp / granule;
    if (groups < count)
        throw Error(std::to_string(count) + " parts of " + std::to_string(job_spp) +
                    " samples per pixel leave some parts empty (each takes at least " +
                    std::to_string(granule) + ")");
    // Boundaries at whole granules, as even as they come.
    SamplePart p;
    p.first = groups * index / count * granule;
    p.end = groups * (index + 1) / count * granule;
    p.job_spp = job_spp;
    return p;
}

void parse_part(const std::string& text, uint32_t& index, uint32_t& count) {
    unsigned i = 0, n = 0;
    char tail = 0;
    if (std::sscanf(text.c_str(), "%u/%u%c", &i, &n, &tail) != 2 || n == 0 || i == 0 || i > n ||
        n > 1000000)
        throw Error("--part takes I/N with 1 <= I <= N (part I of N), not '" + text + "'");
    index = i - 1, count = n;
}

MergeResult merge_parts(const std::vector<std::string>& paths, bool allow_missing) {
    if (paths.empty()) throw Error("no parts to merge");
    // First every part's header (fingerprint, size, range), checked; then the sums, one part
    // at a time, added in sample order: memory for the image and one part, whatever their
    // number.
    struct Part {
        std::string path;
        Fingerprint f;
        RenderResult head;            // no arrays
        uint64_t first = 0, end = 0;  // the range it was given
    };
    std::vector<Part> parts;
    MergeResult m;
    for (const std::string& path : paths) {
        Part p{path, {}, {}, 0, 0};
        p.head = read_checkpoint_header(path, p.f);
        unsigned long long first = 0, end = 0, job = 0;
        char tail = 0;
        const std::string samples = fingerprint_value(p.f, "samples");
        if (std::sscanf(samples.c_str(), "%llu-%llu of %llu%c", &first, &end, &job, &tail) != 3)
            throw Error("'" + path + "' is not a part of a render in parts (render --part I/N)");
        if (!(first < end && end <= job))
            throw Error("'" + path + "' is corrupted: its part " + samples +
                        " does not lie within its job");
        p.first = first, p.end = end;
        // (No wrap: spp is compared with the room left in the part.)
        if (p.head.first != p.first || p.head.spp > p.end - p.first)
            throw Error("'" + path + "' is corrupted: its samples lie outside its part");
        // One job: every key but the device (and the part's own range) the same as the
        // first's, both ways (a key missing from either is a difference).
        if (!parts.empty()) {
            const Part& a = parts.front();
            const std::string key = fingerprint_difference(p.f, a.f, {"device", "samples"});
            if (!key.empty())
                throw Error("'" + path + "' belongs to another job than '" + a.path + "': " + key +
                            " " + fingerprint_value(p.f, key) +
                            " (there: " + fingerprint_value(a.f, key) + ")");
            if (job != m.job_spp)
                throw Error("'" + path + "' is a part of a job of " + std::to_string(job) +
                            " spp, '" + a.path + "' of " + std::to_string(m.job_spp));
            if (p.head.width != a.head.width || p.head.height != a.head.height)
                throw Error("'" + path + "' is corrupted: its image is " +
                            std::to_string(p.head.width) + "x" + std::to_string(p.head.height) +
                            ", '" + a.path + "' " + std::to_string(a.head.width) + "x" +
                            std::to_string(a.head.height));
        }
        m.job_spp = job;
        const std::string device = fingerprint_value(p.f, "device");
        if (std::find(m.devices.begin(), m.devices.end(), device) == m.devices.end())
            m.devices.push_back(device);
        parts.push_back(std::move(p));
    }
    // In sample order: no two ranges may overlap; what no part holds is missing.
    std::sort(parts.begin(), parts.end(),
              [](const Part& a, const Part& b) { return a.first < b.first; });
    uint64_t covered = 0;  // the end of the ranges so far
    std::string gaps;
    const auto gap = [&](uint64_t from, uint64_t to) {
        m.missing_spp += to - from;
        gaps += "  missing: samples " + std::to_string(from) + "-" + std::to_string(to) + "\n";
    };
    for (size_t i = 0; i < parts.size(); ++i) {
        const Part& p = parts[i];
        if (i > 0 && p.first < covered)
            throw Error("'" + p.path + "' overlaps '" + parts[i - 1].path + "': samples " +
                        std::to_string(p.first) + "-" + std::to_string(p.end) + " and " +
                        std::to_string(parts[i - 1].first) + "-" +
                        std::to_string(parts[i - 1].end));
        if (p.first > covered) gap(covered, p.first);
        const uint64_t done = p.head.first + p.head.spp;
        m.report +=
            "  " + p.path + ": samples " + std::to_string(p.first) + "-" + std::to_string(done) +
            (done < p.end ? " of " + std::to_string(p.first) + "-" + std::to_string(p.end) : "") +
            "\n";
        if (done < p.end) gap(done, p.end);
        covered = p.end;
    }
    if (covered < m.job_spp) gap(covered, m.job_spp);
    m.report += gaps;
    if (m.missing_spp > 0 && !allow_missing)
        throw Error("the parts miss " + std::to_string(m.missing_spp) + " of " +
                    std::to_string(m.job_spp) + " samples per pixel:\n" + gaps +
                    "(--allow-missing merges what is there)");
    // The sums, one part at a time (each read again whole, checksum included, and checked to
    // be the part whose header was read).
    for (const Part& p : parts) {
        if (p.head.spp == 0) continue;
        Fingerprint again;
        RenderResult sums = read_checkpoint(p.path, again);
        if (again != p.f || sums.first != p.head.first || sums.spp != p.head.spp ||
            sums.width != p.head.width || sums.height != p.head.height)
            throw Error("'" + p.path + "' changed while it was merged");
        // Added as if adjacent: the sums do not depend on where a sample range sits.
        sums.first = m.sums.first + m.sums.spp;
        add_sums(m.sums, sums);
    }
    if (m.sums.spp == 0) throw Error("the parts hold no samples");
    m.sums.first = 0;
    m.sums.materialize();
    return m;
}

}  // namespace mcpt
