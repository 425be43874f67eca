// Scenes built in code: the Cornell box (the default), a closed white furnace whose exact
// radiance is known, for testing the integrators, a spheres-only scene, and the Cornell box
// with glTF metallic-roughness materials.
#pragma once
#include <string>
#include <vector>

#include "common/scene/scene.h"

namespace mcpt {

// The valid names for make_builtin_scene(), the default ("cornell") first.
std::vector<std::string> builtin_scene_names();

// "cornell" | "furnace" | "spheres" | "materials"; throws mcpt::Error listing the valid names
// otherwise.
Scene make_builtin_scene(const std::string& name);

// The Cornell box with its spheres replaced by a bumpy tessellated sphere of 2 * segments^2
// diffuse triangles (a mesh deep enough for a deep SAH tree; the bench's stand-in model).
Scene make_bumpy_sphere_scene(int segments);

// A closed furnace in which every surface is diffuse with the same grey albedo and emission, so
// the radiance everywhere is emission / (1 - albedo). albedo in [0, 1), emission > 0 (finite),
// otherwise throws mcpt::Error.
Scene make_furnace_scene(float albedo, float emission);

}  // namespace mcpt
