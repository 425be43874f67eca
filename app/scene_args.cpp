#include <algorithm>
#include <iostream>

#include "app/commands.h"
#include "common/builtin_scenes.h"
#include "common/error.h"
#include "common/gltf_loader.h"

namespace mcpt {

namespace {
bool ends_with(const std::string& s, const std::string& suffix) {
    if (s.size() < suffix.size()) return false;
    std::string tail = s.substr(s.size() - suffix.size());
    std::transform(tail.begin(), tail.end(), tail.begin(), ::tolower);
    return tail == suffix;
}
}  // namespace

Scene load_scene_argument(const std::string& arg) {
    // A file by extension, else a built-in name.
    Scene scene = (ends_with(arg, ".gltf") || ends_with(arg, ".glb")) ? load_gltf(arg)
                                                                       : make_builtin_scene(arg);
    for (const std::string& w : scene.warnings) std::cerr << "mcpt: warning: " << w << "\n";
    const ValidationReport report = validate_scene(scene);
    if (report.degenerate_dropped > 0) {
        std::cerr << "mcpt: warning: dropped " << report.degenerate_dropped
                  << " degenerate (zero-area or collinear) triangles\n";
    }
    return scene;
}

TreeOptions tree_options(const std::string& kind, int depth) {
    TreeOptions o;
    o.kind = parse_tree_kind(kind);
    if (depth < -1 || depth > 60) throw Error("--depth must be between 0 and 60");
    o.max_depth = depth;
    return o;
}

}  // namespace mcpt
