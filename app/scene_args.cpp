#include <iostream>

#include "app/commands.h"

namespace mcpt {

Scene load_scene_argument(const std::string& arg) {
    Scene scene = load_scene(arg);
    for (const std::string& w : scene.warnings) std::cerr << "mcpt: warning: " << w << "\n";
    return scene;
}

}  // namespace mcpt
