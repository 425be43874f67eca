// glTF 2.0 (.gltf with external or data-URI buffers, and .glb) to the scene model; see the comment
// block at the top of gltf_loader.cpp for how materials are mapped.
#pragma once
#include <string>

#include "scene.h"

namespace mcpt {

// Loads the default scene (or scene 0) of a glTF file: triangle meshes in world space, materials
// and the first perspective camera (none: frame_camera()). Unsupported features add a line to
// Scene::warnings; a missing, malformed or unsupported file throws mcpt::Error naming the file.
// Does not call validate_scene(): the caller does.
Scene load_gltf(const std::string& path);

}  // namespace mcpt
