#include <iostream>

#include "app/commands.h"
#include "common/scene/environment.h"

namespace mcpt {

Scene load_scene_argument(const std::string& arg) {
    Scene scene = load_scene(arg);
    for (const std::string& w : scene.warnings) std::cerr << "mcpt: warning: " << w << "\n";
    return scene;
}

void add_lighting_options(CLI::App* sub, LightingArgs& a) {
    auto* env = sub->add_option("--env", a.env,
                                "Environment map lighting the scene (equirectangular, linear "
                                ".exr or .hdr; +Y up)");
    sub->add_option("--env-rotate", a.env_rotate, "Turn the environment about +Y (degrees)")
        ->check(CLI::Range(-1e6, 1e6));
    sub->add_option("--env-scale", a.env_scale, "Scale the environment's radiance")
        ->check(CLI::Range(0.0, 1e30));
    sub->add_option("--background", a.background,
                    "Constant background radiance R,G,B lighting the scene (default: black)")
        ->delimiter(',')
        ->expected(3)
        ->excludes(env);
}

Environment lighting_environment(const LightingArgs& a) {
    Environment env;
    if (!a.env.empty()) {
        env = load_environment(a.env);
    } else if (!a.background.empty()) {
        const glm::vec3 rgb(a.background[0], a.background[1], a.background[2]);
        env = constant_environment(rgb);                                   // checks the values
        if (!(rgb.x > 0 || rgb.y > 0 || rgb.z > 0)) return Environment{};  // black: no light
    }
    env.rotate_deg = a.env_rotate;
    env.scale = a.env_scale;
    return env;
}

std::vector<std::string> device_specs(const std::string& backend,
                                      const std::vector<std::string>& devices) {
    if (devices.empty()) return {backend};
    std::vector<std::string> specs;
    for (const std::string& d : devices) {
        const bool has_api = d.rfind("opencl", 0) == 0 || d.rfind("vulkan", 0) == 0;
        specs.push_back(has_api ? d : backend + ":" + d);
    }
    return specs;
}

}  // namespace mcpt
