// Build-time tool: inlines the project's own #include "..." lines of a device source
// (recursively, each file once) and writes it as a C++ string constant.
// Usage: embed_source [--raw] INPUT OUTPUT SYMBOL (--raw: the file as it is, e.g. a web page)
#include <filesystem>
#include <fstream>
#include <iostream>
#include <regex>
#include <set>
#include <sstream>
#include <string>

namespace fs = std::filesystem;

static bool inline_file(const fs::path& path, std::set<fs::path>& seen, std::ostream& out) {
    const fs::path canonical = fs::weakly_canonical(path);
    if (!seen.insert(canonical).second) return true;
    std::ifstream in(path);
    if (!in) {
        std::cerr << "embed_source: cannot open " << path << "\n";
        return false;
    }
    static const std::regex include_re(R"(^\s*#\s*include\s+\"([^\"]+)\")");
    std::string line;
    int number = 0;
    out << "#line 1 \"" << path.filename().string() << "\"\n";
    while (std::getline(in, line)) {
        ++number;
        std::smatch m;
        if (std::regex_search(line, m, include_re)) {
            if (!inline_file(path.parent_path() / m[1].str(), seen, out)) return false;
            out << "#line " << number + 1 << " \"" << path.filename().string() << "\"\n";
        } else {
            out << line << "\n";
        }
    }
    return true;
}

int main(int argc, char** argv) {
    const bool raw = argc == 5 && std::string(argv[1]) == "--raw";
    if (raw) ++argv, --argc;
    if (argc != 4) {
        std::cerr << "usage: embed_source [--raw] INPUT OUTPUT SYMBOL\n";
        return 2;
    }
    std::set<fs::path> seen;
    std::ostringstream text;
    if (raw) {
        std::ifstream in(argv[1], std::ios::binary);
        if (!in) {
            std::cerr << "embed_source: cannot open " << argv[1] << "\n";
            return 1;
        }
        text << in.rdbuf();
    } else if (!inline_file(argv[1], seen, text)) {
        return 1;
    }
    const std::string s = text.str();
    std::ofstream out(argv[2]);
    out << "// Generated from " << fs::path(argv[1]).filename().string() << "; do not edit.\n";
    out << "#pragma once\nstatic const char " << argv[3] << "[] = {\n";
    for (size_t i = 0; i < s.size(); ++i) {
        // Bytes above 127 (UTF-8 in a web page) cast: char is signed on some targets.
        const int byte = static_cast<unsigned char>(s[i]);
        if (byte > 127) out << "(char)";
        out << byte << ",";
        if (i % 24 == 23) out << "\n";
    }
    out << "0};\n";
    return out ? 0 : 1;
}
