// glTF 2.0 (.gltf with external or data-URI buffers, and .glb) to the scene model; see the comment
// block at the top of gltf_loader.cpp for how materials are mapped.
#pragma once
#include <cstddef>
#include <string>

#include "common/scene/scene.h"

namespace mcpt {

// Loads the default scene (or scene 0) of a glTF file: triangle meshes in world space, materials
// and the first perspective camera (none: frame_camera()). Unsupported features add a line to
// Scene::warnings; a missing, malformed or unsupported file throws mcpt::Error naming the file.
// Does not call validate_scene(): the caller does.
Scene load_gltf(const std::string& path);

// The same from a .glb or .gltf held in memory (an Android app's asset), named `name` in
// messages. External buffers are read from `base_dir` only; with none (""), a URI that is not
// a data URI is an error and the file system is never touched.
Scene load_gltf_memory(const void* data, size_t size, const std::string& name,
                       const std::string& base_dir = "");

}  // namespace mcpt
