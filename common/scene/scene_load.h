// A scene from whatever a client holds: a built-in name, a .gltf/.glb path, or the bytes of
// one in memory. Every way validates the scene and keeps what it dropped or ignored as
// warnings, so clients only print them.
#pragma once
#include <cstddef>
#include <string>

#include "common/scene/scene.h"

namespace mcpt {

// A .gltf/.glb path (by extension), else a built-in scene name; validated.
Scene load_scene(const std::string& name_or_path);

// A .glb or .gltf in memory (see load_gltf_memory); validated.
Scene load_scene_memory(const void* data, size_t size, const std::string& name = "memory",
                        const std::string& base_dir = "");

// The glTF extensions a scene's file uses, comma-separated ("" for none).
std::string extension_list(const Scene& scene);

// Bounces per path when a client asks for none: the scene's own hint (the furnace asks for
// unlimited) or kDefaultMaxDepth.
constexpr int kDefaultMaxDepth = 8;
int default_max_depth(const Scene& scene);

}  // namespace mcpt
