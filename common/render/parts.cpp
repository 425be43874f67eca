#include "common/render/parts.h"

#include <algorithm>
#include <cstdio>

#include "common/error.h"
#include "common/render/checkpoint.h"

namespace mcpt {

namespace {
std::string value_of(const Fingerprint& f, const std::string& key) {
    for (const auto& [k, v] : f)
        if (k == key) return v;
    return "";
}
}  // namespace

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
    struct Part {
        std::string path;
        Fingerprint f;
        RenderResult sums;
        uint64_t first = 0, end = 0;  // the range it was given
    };
    std::vector<Part> parts;
    MergeResult m;
    for (const std::string& path : paths) {
        Part p{path, {}, {}, 0, 0};
        p.sums = read_checkpoint(path, p.f);
        unsigned long long first = 0, end = 0, job = 0;
        const std::string samples = value_of(p.f, "samples");
        if (std::sscanf(samples.c_str(), "%llu-%llu of %llu", &first, &end, &job) != 3)
            throw Error("'" + path + "' is not a part of a render in parts (render --part I/N)");
        p.first = first, p.end = end;
        if (p.sums.first != p.first || p.sums.first + p.sums.spp > p.end)
            throw Error("'" + path + "' is corrupted: its samples lie outside its part");
        // One job: every key but the device (and the part's own range) the same as the first.
        if (!parts.empty()) {
            const Part& a = parts.front();
            for (const auto& [key, value] : p.f) {
                if (key == "device" || key == "samples") continue;
                if (value_of(a.f, key) != value)
                    throw Error("'" + path + "' belongs to another job than '" + a.path +
                                "': " + key + " " + value + " (there: " + value_of(a.f, key) + ")");
            }
            if (job != m.job_spp)
                throw Error("'" + path + "' is a part of a job of " + std::to_string(job) +
                            " spp, '" + a.path + "' of " + std::to_string(m.job_spp));
        }
        m.job_spp = job;
        const std::string device = value_of(p.f, "device");
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
        Part& p = parts[i];
        if (i > 0 && p.first < covered)
            throw Error("'" + p.path + "' overlaps '" + parts[i - 1].path + "': samples " +
                        std::to_string(p.first) + "-" + std::to_string(p.end) + " and " +
                        std::to_string(parts[i - 1].first) + "-" +
                        std::to_string(parts[i - 1].end));
        if (p.first > covered) gap(covered, p.first);
        const uint64_t done = p.sums.first + p.sums.spp;
        m.report +=
            "  " + p.path + ": samples " + std::to_string(p.first) + "-" + std::to_string(done) +
            (done < p.end ? " of " + std::to_string(p.first) + "-" + std::to_string(p.end) : "") +
            "\n";
        if (done < p.end) gap(done, p.end);
        covered = p.end;
        // Added as if adjacent: the sums do not depend on where a sample range sits.
        if (p.sums.spp == 0) continue;
        p.sums.first = m.sums.first + m.sums.spp;
        add_sums(m.sums, p.sums);
    }
    if (covered < m.job_spp) gap(covered, m.job_spp);
    m.report += gaps;
    if (m.missing_spp > 0 && !allow_missing)
        throw Error("the parts miss " + std::to_string(m.missing_spp) + " of " +
                    std::to_string(m.job_spp) + " samples per pixel:\n" + gaps +
                    "(--allow-missing merges what is there)");
    if (m.sums.spp == 0) throw Error("the parts hold no samples");
    m.sums.first = 0;
    m.sums.materialize();
    return m;
}

}  // namespace mcpt
