// Checkpoints: a session's accumulation on disk, to resume a render stopped by a kill, a
// device loss or a power cut. A file holds a fingerprint (mcpt version, scene content hash,
// every setting that changes the image, the device) as "key=value" lines, the sums, and a
// checksum; a checkpoint that does not match is refused, naming what differs.
#pragma once
#include <string>
#include <utility>
#include <vector>

#include "common/render/render_loop.h"
#include "common/scene/scene.h"

namespace mcpt {

using Fingerprint = std::vector<std::pair<std::string, std::string>>;

// "key=value" lines, and back (lines without '=' are skipped).
std::string encode_fingerprint(const Fingerprint& f);
Fingerprint decode_fingerprint(const std::string& text);
// The first key whose value differs between a and b, either way (a key missing from one is a
// difference), `ignored` keys aside; empty when they agree.
std::string fingerprint_difference(const Fingerprint& a, const Fingerprint& b,
                                   const std::vector<std::string>& ignored = {});
// A key's value, or "(missing)".
std::string fingerprint_value(const Fingerprint& f, const std::string& key);

// 64-bit FNV-1a of everything in the scene that reaches the image: geometry, materials,
// camera, bounce hint.
uint64_t scene_hash(const Scene& scene);

// Writes `sums` (spp, sums, squares, invalid counts, rays, seconds) with `fingerprint` to
// `path`, atomically and synced to disk. Throws mcpt::Error.
void write_checkpoint(const std::string& path, const Fingerprint& fingerprint,
                      const RenderResult& sums);

// Reads a checkpoint written for `expected` (same keys, same values, same order); throws
// mcpt::Error naming the path and the first difference: "written by mcpt 0.1.0, this is
// 0.2.0", "for another scene", "width 256 (now 512)", or "truncated" / "corrupted".
RenderResult read_checkpoint(const std::string& path, const Fingerprint& expected);
// Reads a checkpoint whatever it was written for; `written` receives its fingerprint.
RenderResult read_checkpoint(const std::string& path, Fingerprint& written);
// Its fingerprint and header alone (size, samples, first, rays, seconds; no sums): read and
// checked against the file's size, the arrays not read.
RenderResult read_checkpoint_header(const std::string& path, Fingerprint& written);
// From memory (the fuzz target), as read_checkpoint(path, written).
RenderResult read_checkpoint_memory(const void* data, size_t size, Fingerprint& written);
// Every checkpoint is read header first (at most 64 KiB of fingerprint), then exactly
// the arrays the header implies: a file of another size is refused before they are read.

}  // namespace mcpt
