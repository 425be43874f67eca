#include "common/io/host_memory.h"

#include <unistd.h>

#include <cstdio>

namespace mcpt {

uint64_t host_memory_available() {
    if (FILE* f = std::fopen("/proc/meminfo", "r")) {
        char line[256];
        unsigned long long kib = 0;
        while (std::fgets(line, sizeof line, f))
            if (std::sscanf(line, "MemAvailable: %llu kB", &kib) == 1) break;
        std::fclose(f);
        if (kib > 0) return uint64_t(kib) * 1024;
    }
    const long pages = sysconf(_SC_PHYS_PAGES), size = sysconf(_SC_PAGE_SIZE);
    return pages > 0 && size > 0 ? uint64_t(pages) * uint64_t(size) : UINT64_MAX;
}

std::string human_bytes(uint64_t b) {
    char text[32];
    if (b >= (1ull << 30))
        std::snprintf(text, sizeof text, "%.3g GiB", double(b) / double(1ull << 30));
    else if (b >= (1ull << 20))
        std::snprintf(text, sizeof text, "%.3g MiB", double(b) / double(1ull << 20));
    else
        std::snprintf(text, sizeof text, "%llu B", (unsigned long long)b);
    return text;
}

}  // namespace mcpt
