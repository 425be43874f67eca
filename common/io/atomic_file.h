// Files written whole or not at all: into a temporary file beside the target, then renamed
// over it (rename is atomic within a folder on POSIX), so a crash mid-write never leaves a
// partial file under the final name, and an older file there stays intact until the new one
// is complete.
#pragma once
#include <functional>
#include <string>

namespace mcpt {

// Calls write(tmp) to fill a temporary path beside `path`, then renames it to `path`. If
// write throws or the rename fails, the temporary file is removed and mcpt::Error (or write's
// exception) propagates; `path` is untouched.
void write_atomically(const std::string& path,
                      const std::function<void(const std::string&)>& write);

// Writes `text` to `path` that way.
void write_text_atomically(const std::string& path, const std::string& text);

}  // namespace mcpt
