#include "common/scene/scene_load.h"

#include <algorithm>
#include <cctype>

#include "common/error.h"
#include "common/scene/builtin_scenes.h"
#include "common/scene/gltf_loader.h"

namespace mcpt {

namespace {

bool ends_with(const std::string& s, const std::string& suffix) {
    if (s.size() < suffix.size()) return false;
    std::string tail = s.substr(s.size() - suffix.size());
    std::transform(tail.begin(), tail.end(), tail.begin(),
                   [](unsigned char c) { return std::tolower(c); });
    return tail == suffix;
}

Scene validated(Scene scene) {
    const ValidationReport report = validate_scene(scene);
    if (report.degenerate_dropped > 0) {
        scene.warnings.push_back("dropped " + std::to_string(report.degenerate_dropped) +
                                 " degenerate (zero-area or collinear) triangles");
    }
    return scene;
}

}  // namespace

Scene load_scene(const std::string& arg) {
    // A file by extension, else a built-in name.
    if (!ends_with(arg, ".gltf") && !ends_with(arg, ".glb"))
        return validated(make_builtin_scene(arg));
    Scene scene = load_gltf(arg);
    try {
        return validated(std::move(scene));
    } catch (const Error& e) {
        // World-space checks (after node transforms): say which file.
        throw Error(arg + ": " + e.what() + " (in world space, after node transforms)");
    }
}

Scene load_scene_memory(const void* data, size_t size, const std::string& name,
                        const std::string& base_dir) {
    return validated(load_gltf_memory(data, size, name, base_dir));
}

int default_max_depth(const Scene& scene) {
    return scene.max_depth_hint > 0 ? scene.max_depth_hint : kDefaultMaxDepth;
}

std::string extension_list(const Scene& scene) {
    std::string out;
    for (const std::string& e : scene.extensions) out += (out.empty() ? "" : ", ") + e;
    return out;
}

}  // namespace mcpt
