#include "common/io/atomic_file.h"

#include <fcntl.h>
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <fstream>

#include "common/error.h"

namespace mcpt {

void write_atomically(const std::string& path,
                      const std::function<void(const std::string&)>& write) {
    // Beside the target (same folder, so the rename cannot cross file systems), hidden, unique
    // per process.
    const std::filesystem::path p(path);
    const std::string tmp =
        (p.parent_path() / ("." + p.filename().string() + ".tmp" + std::to_string(getpid())))
            .string();
    try {
        write(tmp);
    } catch (const Error& e) {
        // The message names the file asked for, not the temporary one.
        std::remove(tmp.c_str());
        std::string m = e.what();
        for (size_t at = m.find(tmp); at != std::string::npos; at = m.find(tmp, at + path.size()))
            m.replace(at, tmp.size(), path);
        throw Error(m);
    } catch (...) {
        std::remove(tmp.c_str());
        throw;
    }
    // On disk before it takes the name (a power cut then leaves the old file or the new one),
    // and the rename itself on disk after.
    const auto sync = [](const std::string& file) {
        const int fd = ::open(file.c_str(), O_RDONLY | O_CLOEXEC);
        const bool ok = fd >= 0 && ::fsync(fd) == 0;
        if (fd >= 0) ::close(fd);
        return ok;
    };
    if (!sync(tmp)) {
        std::remove(tmp.c_str());
        throw Error("cannot write '" + path + "': the data did not reach the disk (fsync)");
    }
    if (std::rename(tmp.c_str(), path.c_str()) != 0) {
        std::remove(tmp.c_str());
        throw Error("cannot write '" + path + "': renaming the finished temporary file failed");
    }
    sync(p.parent_path().empty() ? "." : p.parent_path().string());
}

void write_text_atomically(const std::string& path, const std::string& text) {
    write_atomically(path, [&](const std::string& tmp) {
        std::ofstream f(tmp, std::ios::binary);
        f << text;
        f.flush();
        if (!f) throw Error("cannot write '" + path + "'");
    });
}

}  // namespace mcpt
