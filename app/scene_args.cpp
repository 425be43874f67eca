#include <algorithm>
#include <iostream>

#include "app/commands.h"
#include "common/error.h"
#include "common/scene/environment.h"

namespace mcpt {

Scene load_scene_argument(const std::string& arg) {
    Scene scene = load_scene(arg);
    for (const std::string& w : scene.warnings) std::cerr << "mcpt: warning: " << w << "\n";
    return scene;
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
    env.compensated = a.env_sampling == "compensated";
    return env;
}

void print_device_shares(const Session& session) {
    const uint64_t spp = session.result().spp;
    // The render time: what a device did not spend in chunks went to hand-outs, read-backs
    // and the sums' collection, or to waiting for the round's last chunk.
    const double seconds = session.result().seconds;
    for (size_t d = 0; d < session.device_stats().size(); ++d) {
        const WorkerStats& w = session.device_stats()[d];
        std::printf(
            "  device %zu: %s: %llu chunks, %llu spp (%.0f%%), %.2f spp/s, in chunks %.1f%% "
            "of the time, read-backs %.3f s\n",
            d, w.name.c_str(), (unsigned long long)w.chunks, (unsigned long long)w.samples,
            spp > 0 ? 100.0 * double(w.samples) / double(spp) : 0.0,
            w.seconds > 0 ? double(w.samples) / w.seconds : 0.0,
            seconds > 0 ? 100 * w.seconds / seconds : 0.0, w.finish_seconds);
    }
}

void apply_light_sampling(Scene& scene, const LightingArgs& lighting) {
    using Tls = Scene::TriangleLightSampling;
    const std::string& tls = lighting.triangle_light_sampling;
    scene.triangle_light_sampling = tls == "area"        ? Tls::Area
                                    : tls == "triangles" ? Tls::Triangles
                                    : tls == "cosine"    ? Tls::Cosine
                                    : tls == "uniform"   ? Tls::Uniform
                                                         : Tls::SolidAngle;
    const std::string& how = lighting.light_sampling;
    if (how == "contribution" && !scene.lamp_choice_possible())
        throw Error(
            "--light-sampling contribution: every light must be a lamp (point, spot or "
            "directional; no emissive surface, no environment), at most " +
            std::to_string(Scene::kLampChoiceMax) + " of them");
    if (how == "auto") {
        scene.choose_lights_automatically();
        return;
    }
    scene.light_by_contribution = how == "contribution";
    scene.light_tree = how == "tree";
}

}  // namespace mcpt
