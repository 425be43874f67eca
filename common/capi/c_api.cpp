// include/mcpt/mcpt.h over the engine, sections 1 to 9 (devices and sessions; the jobs are in
// c_api_jobs.cpp): handles are ids in a table (never pointers that a stale handle could
// reach), every entry point catches everything, and messages are kept per session (or per
// thread where there is no session).
#include <cmath>

#include "common/capi/c_api_internal.h"
#include "common/render/device_registry.h"
#include "common/render/prepare.h"
#include "common/render/scene_features.h"
#include "common/render/session.h"
#include "common/scene/environment.h"
#include "common/scene/scene_load.h"
#include "mcpt/mcpt.h"

namespace {

using mcpt::Session;
using namespace mcpt::capi;

struct SessionBox {
    std::mutex mutex;  // serialises calls on the session (cancel does not take it)
    std::unique_ptr<Session> session;
    std::string last_error;  // guarded by error_mutex
    std::mutex error_mutex;
};

HandleTable<SessionBox, mcpt_session>& handles() {
    // Never destroyed: safe from atexit order.
    static auto* h = new HandleTable<SessionBox, mcpt_session>(0x6d637074000ull);
    return *h;
}

mcpt_status box_fail(SessionBox& box, mcpt_status status, const std::string& message) {
    std::lock_guard<std::mutex> lock(box.error_mutex);
    box.last_error = message;
    return status;
}

std::shared_ptr<SessionBox> lookup(mcpt_session s, bool remove, mcpt_status& st) {
    return mcpt::capi::lookup(handles(), s, remove, st, "session");
}

// Looks up the session and runs body(Session&) under its lock.
template <class Body>
mcpt_status with_session(mcpt_session s, mcpt_status context, Body&& body) {
    mcpt_status st = MCPT_OK;
    const std::shared_ptr<SessionBox> box = lookup(s, false, st);
    if (!box) return st;
    std::string message;
    {
        std::lock_guard<std::mutex> lock(box->mutex);
        if (!box->session) {
            return box_fail(*box, MCPT_ERROR_INVALID_HANDLE, "session is being released");
        }
        st = guarded(context, message, [&] { return body(*box->session); });
    }
    if (st != MCPT_OK && st != MCPT_CANCELLED) box_fail(*box, st, message);
    return st;
}

// The session's scene is loaded; else an out-of-order error.
void require_scene(const Session& s) {
    if (!s.has_scene())
        throw CError{MCPT_ERROR_INVALID_STATE, "no scene loaded (load one before rendering)"};
}
void require_image(const Session& s) {
    if (s.spp() == 0)
        throw CError{MCPT_ERROR_INVALID_STATE, "nothing rendered yet (call mcpt_session_render)"};
}

}  // namespace

namespace mcpt::capi {

mcpt_device_info device_info(const DeviceInfo& d) {
    mcpt_device_info out;
    std::memset(&out, 0, sizeof out);
    copy(out.api, sizeof out.api, d.backend);
    out.index = d.index;
    copy(out.name, sizeof out.name, d.name);
    copy(out.platform, sizeof out.platform, d.platform);
    copy(out.type, sizeof out.type, d.type);
    copy(out.spec, sizeof out.spec, d.backend + ":" + std::to_string(d.index));
    return out;
}

Scene scene_from_file(const char* path) {
    require(path != nullptr && *path, "path is NULL or empty");
    Scene scene = load_scene(path);
    scene.choose_lights_automatically();
    return scene;
}

Scene scene_from_memory(const void* data, size_t size, const char* base_dir) {
    require(data != nullptr || size == 0, "data is NULL");
    Scene scene = load_scene_memory(data, size, "memory", base_dir ? base_dir : "");
    scene.choose_lights_automatically();
    return scene;
}

Scene scene_builtin(const char* name) {
    require(name != nullptr, "name is NULL");
    Scene scene = load_scene(name);
    scene.choose_lights_automatically();
    return scene;
}

}  // namespace mcpt::capi

extern "C" {

int mcpt_version(void) {
    return MCPT_VERSION_MAJOR * 10000 + MCPT_VERSION_MINOR * 100 + MCPT_VERSION_PATCH;
}

const char* mcpt_version_string(void) {
    return MCPT_VERSION_STRING;
}

const char* mcpt_status_name(mcpt_status status) {
    // A C caller may pass any int: read its bits as one (in C++ loading an enum outside its
    // enumerators' range is undefined, and clang's UBSan stops there).
    int code = 0;
    static_assert(sizeof(code) == sizeof(status), "mcpt_status is an int");
    std::memcpy(&code, &status, sizeof(code));
    switch (code) {
        case MCPT_OK:
            return "MCPT_OK";
        case MCPT_CANCELLED:
            return "MCPT_CANCELLED";
        case MCPT_ERROR_INVALID_ARGUMENT:
            return "MCPT_ERROR_INVALID_ARGUMENT";
        case MCPT_ERROR_INVALID_HANDLE:
            return "MCPT_ERROR_INVALID_HANDLE";
        case MCPT_ERROR_INVALID_STATE:
            return "MCPT_ERROR_INVALID_STATE";
        case MCPT_ERROR_SCENE:
            return "MCPT_ERROR_SCENE";
        case MCPT_ERROR_DEVICE:
            return "MCPT_ERROR_DEVICE";
        case MCPT_ERROR_IO:
            return "MCPT_ERROR_IO";
        case MCPT_ERROR_OUT_OF_MEMORY:
            return "MCPT_ERROR_OUT_OF_MEMORY";
        case MCPT_ERROR_INTERNAL:
            return "MCPT_ERROR_INTERNAL";
        case MCPT_ERROR_DEVICE_LOST:
            return "MCPT_ERROR_DEVICE_LOST";
    }
    return "unknown status";
}

const char* mcpt_last_error(mcpt_session s) {
    return last_error_of(handles(), s);
}

mcpt_status mcpt_devices(mcpt_device_info* devices, size_t capacity, size_t* count) {
    std::string message;
    const mcpt_status st = guarded(MCPT_ERROR_DEVICE, message, [&] {
        require(count != nullptr, "count is NULL");
        require(devices != nullptr || capacity == 0, "devices is NULL with a capacity > 0");
        const std::vector<mcpt::DeviceInfo> all = mcpt::list_devices();
        for (size_t i = 0; i < all.size() && i < capacity; ++i) devices[i] = device_info(all[i]);
        *count = all.size();
        return MCPT_OK;
    });
    return st == MCPT_OK ? st : thread_fail(st, message);
}

mcpt_status mcpt_session_create_devices(const char* const* devices, size_t count,
                                        mcpt_session* out) {
    std::string message;
    const mcpt_status st = guarded(MCPT_ERROR_DEVICE, message, [&] {
        require(out != nullptr, "out is NULL");
        *out = nullptr;
        require(devices != nullptr || count == 0, "devices is NULL");
        require(count >= 1 && count <= 64, "count must be 1 to 64");
        std::vector<std::string> specs;
        for (size_t i = 0; i < count; ++i) specs.push_back(devices[i] ? devices[i] : "");
        auto box = std::make_shared<SessionBox>();
        box->session = std::make_unique<Session>(specs, mcpt::BackendOptions{});
        *out = handles().add(std::move(box));
        return MCPT_OK;
    });
    return st == MCPT_OK ? st : thread_fail(st, message);
}

mcpt_status mcpt_session_create(const char* device, mcpt_session* out) {
    std::string message;
    const mcpt_status st = guarded(MCPT_ERROR_DEVICE, message, [&] {
        require(out != nullptr, "out is NULL");
        *out = nullptr;
        auto box = std::make_shared<SessionBox>();
        box->session = std::make_unique<Session>(device ? device : "");
        *out = handles().add(std::move(box));
        return MCPT_OK;
    });
    return st == MCPT_OK ? st : thread_fail(st, message);
}

mcpt_status mcpt_session_release(mcpt_session s) {
    mcpt_status found = MCPT_OK;
    const std::shared_ptr<SessionBox> box = lookup(s, true, found);
    if (!box) return found;
    // Stop a render in progress, wait for it, then free the device.
    std::string message;
    const mcpt_status st = guarded(MCPT_ERROR_INTERNAL, message, [&] {
        {
            std::lock_guard<std::mutex> lock(box->error_mutex);
            if (box->session) box->session->cancel();
        }
        std::lock_guard<std::mutex> lock(box->mutex);
        box->session.reset();
        return MCPT_OK;
    });
    return st == MCPT_OK ? st : thread_fail(st, message);
}

mcpt_status mcpt_session_device(mcpt_session s, mcpt_device_info* out) {
    return with_session(s, MCPT_ERROR_DEVICE, [&](Session& session) {
        require(out != nullptr, "out is NULL");
        *out = device_info(session.device());
        return MCPT_OK;
    });
}

mcpt_status mcpt_session_load_file(mcpt_session s, const char* path) {
    return with_session(s, MCPT_ERROR_SCENE, [&](Session& session) {
        session.set_scene(scene_from_file(path));
        return MCPT_OK;
    });
}

mcpt_status mcpt_session_load_memory(mcpt_session s, const void* data, size_t size,
                                     const char* base_dir) {
    return with_session(s, MCPT_ERROR_SCENE, [&](Session& session) {
        session.set_scene(scene_from_memory(data, size, base_dir));
        return MCPT_OK;
    });
}

mcpt_status mcpt_session_load_builtin(mcpt_session s, const char* name) {
    return with_session(s, MCPT_ERROR_SCENE, [&](Session& session) {
        session.set_scene(scene_builtin(name));
        return MCPT_OK;
    });
}

namespace {
mcpt::Environment turned(mcpt::Environment env, float rotate_deg, float scale) {
    require(std::isfinite(rotate_deg), "rotate_deg must be finite");
    require(std::isfinite(scale) && scale >= 0, "scale must be finite and >= 0");
    env.rotate_deg = rotate_deg, env.scale = scale;
    return env;
}
}  // namespace

mcpt_status mcpt_session_set_environment(mcpt_session s, const char* path, float rotate_deg,
                                         float scale) {
    return with_session(s, MCPT_ERROR_SCENE, [&](Session& session) {
        session.set_environment(path ? turned(mcpt::load_environment(path), rotate_deg, scale)
                                     : mcpt::Environment{});
        return MCPT_OK;
    });
}

mcpt_status mcpt_session_set_environment_memory(mcpt_session s, const void* data, size_t size,
                                                float rotate_deg, float scale) {
    return with_session(s, MCPT_ERROR_SCENE, [&](Session& session) {
        require(data != nullptr && size > 0, "data is NULL or empty");
        session.set_environment(turned(
            mcpt::load_environment_memory(static_cast<const unsigned char*>(data), size, "memory"),
            rotate_deg, scale));
        return MCPT_OK;
    });
}

mcpt_status mcpt_session_set_background(mcpt_session s, float r, float g, float b) {
    return with_session(s, MCPT_ERROR_INTERNAL, [&](Session& session) {
        require(std::isfinite(r + g + b) && r >= 0 && g >= 0 && b >= 0,
                "the background must be finite and >= 0");
        session.set_environment(r > 0 || g > 0 || b > 0
                                    ? mcpt::constant_environment(glm::vec3(r, g, b))
                                    : mcpt::Environment{});
        return MCPT_OK;
    });
}

mcpt_status mcpt_session_scene_info(mcpt_session s, mcpt_scene_info* out) {
    return with_session(s, MCPT_ERROR_INTERNAL, [&](Session& session) {
        require(out != nullptr, "out is NULL");
        require_scene(session);
        if (!session.committed())
            throw CError{MCPT_ERROR_INVALID_STATE,
                         "scene not prepared yet (render or mcpt_session_commit first)"};
        std::memset(out, 0, sizeof *out);
        const mcpt::GpuScene& g = session.prepared();
        out->triangles = g.triangles.size(), out->spheres = g.spheres.size();
        out->materials = g.materials.size(), out->lights = g.params.num_lights;
        copy(out->tree, sizeof out->tree, mcpt::tree_kind_name(g.tree_kind));
        copy(out->tree_reason, sizeof out->tree_reason, g.tree_choice);
        copy(out->features, sizeof out->features, mcpt::feature_names(g.features));
        out->max_bounces = session.max_depth();
        return MCPT_OK;
    });
}

mcpt_status mcpt_session_set_size(mcpt_session s, int width, int height) {
    return with_session(s, MCPT_ERROR_INTERNAL, [&](Session& session) {
        require(width >= 1 && height >= 1 && width <= 16384 && height <= 16384,
                "image size must be between 1x1 and 16384x16384");
        session.settings().width = width, session.settings().height = height;
        return MCPT_OK;
    });
}

mcpt_status mcpt_session_set_max_bounces(mcpt_session s, int bounces) {
    return with_session(s, MCPT_ERROR_INTERNAL, [&](Session& session) {
        require(bounces >= -1 && bounces <= 1000000, "bounces must be -1 or 0 to 1000000");
        session.settings().max_depth = bounces;
        return MCPT_OK;
    });
}

mcpt_status mcpt_session_set_tree(mcpt_session s, const char* kind, int depth) {
    return with_session(s, MCPT_ERROR_INTERNAL, [&](Session& session) {
        require(kind != nullptr, "kind is NULL");
        try {
            mcpt::tree_options(kind, depth);  // validates both
        } catch (const mcpt::Error& e) {
            throw CError{MCPT_ERROR_INVALID_ARGUMENT, e.what()};
        }
        session.settings().tree = kind, session.settings().tree_depth = depth;
        return MCPT_OK;
    });
}

mcpt_status mcpt_session_set_seed(mcpt_session s, uint32_t seed) {
    return with_session(s, MCPT_ERROR_INTERNAL, [&](Session& session) {
        session.settings().seed = seed;
        return MCPT_OK;
    });
}

mcpt_status mcpt_session_set_specialize(mcpt_session s, int on) {
    return with_session(s, MCPT_ERROR_INTERNAL, [&](Session& session) {
        session.settings().specialize = on != 0;
        return MCPT_OK;
    });
}

mcpt_status mcpt_session_set_sampler(mcpt_session s, const char* sampler) {
    return with_session(s, MCPT_ERROR_INVALID_ARGUMENT, [&](Session& session) {
        const std::string name = sampler ? sampler : "";
        if (name != "sobol" && name != "independent")
            throw mcpt::Error("unknown sampler '" + name + "' (sobol or independent)");
        session.settings().sampler = name;
        return MCPT_OK;
    });
}

mcpt_status mcpt_session_set_adaptive(mcpt_session s, int on) {
    return with_session(s, MCPT_ERROR_INTERNAL, [&](Session& session) {
        require(on == 0 || !session.settings().reproducible,
                "adaptive sampling is not reproducible (its sample counts follow the noise): "
                "turn reproducible rendering off first");
        session.settings().adaptive = on != 0;
        return MCPT_OK;
    });
}

mcpt_status mcpt_session_set_reproducible(mcpt_session s, int on) {
    return with_session(s, MCPT_ERROR_INTERNAL, [&](Session& session) {
        require(on == 0 || !session.settings().adaptive,
                "adaptive sampling is not reproducible: turn it off first");
        session.settings().reproducible = on != 0;
        return MCPT_OK;
    });
}

mcpt_status mcpt_session_commit(mcpt_session s) {
    return with_session(s, MCPT_ERROR_DEVICE, [&](Session& session) {
        require_scene(session);
        session.commit();
        return MCPT_OK;
    });
}

mcpt_status mcpt_session_render(mcpt_session s, double budget_ms, double target_error,
                                uint64_t max_spp, mcpt_render_stats* stats) {
    return with_session(s, MCPT_ERROR_DEVICE, [&](Session& session) {
        require(std::isfinite(budget_ms) && budget_ms >= 0, "budget_ms must be finite and >= 0");
        require(std::isfinite(target_error) && target_error >= 0,
                "target_error must be finite and >= 0");
        require_scene(session);
        const mcpt::PassStats p = session.render(budget_ms, target_error, max_spp);
        if (stats) {
            stats->samples = p.samples, stats->spp = p.spp, stats->seconds = p.seconds;
            stats->relative_error = std::isfinite(p.relative_error) ? p.relative_error : -1.0;
            stats->target_reached = p.target_reached ? 1 : 0;
        }
        return p.cancelled ? MCPT_CANCELLED : MCPT_OK;
    });
}

mcpt_status mcpt_session_cancel(mcpt_session s) {
    // No session lock: a render holds it.
    mcpt_status found = MCPT_OK;
    const std::shared_ptr<SessionBox> box = lookup(s, false, found);
    if (!box) return found;
    try {
        std::lock_guard<std::mutex> lock(box->error_mutex);
        if (box->session) box->session->cancel();
        return MCPT_OK;
    } catch (...) {
        return thread_fail(MCPT_ERROR_INTERNAL, "internal error in cancel");
    }
}

mcpt_status mcpt_session_reset(mcpt_session s) {
    return with_session(s, MCPT_ERROR_INTERNAL, [&](Session& session) {
        session.reset();
        return MCPT_OK;
    });
}

mcpt_status mcpt_session_image_size(mcpt_session s, int* width, int* height) {
    return with_session(s, MCPT_ERROR_INTERNAL, [&](Session& session) {
        require(width != nullptr && height != nullptr, "width or height is NULL");
        require_image(session);
        *width = session.result().width, *height = session.result().height;
        return MCPT_OK;
    });
}

mcpt_status mcpt_session_read_rgba32f(mcpt_session s, float* pixels, size_t capacity) {
    return with_session(s, MCPT_ERROR_INTERNAL, [&](Session& session) {
        require(pixels != nullptr, "pixels is NULL");
        require_image(session);
        const std::vector<float> img = session.image_rgba32f();
        require(capacity >= img.size(), "buffer too small: needs 4 * width * height floats");
        std::memcpy(pixels, img.data(), img.size() * sizeof(float));
        return MCPT_OK;
    });
}

mcpt_status mcpt_session_read_rgba8(mcpt_session s, uint8_t* pixels, size_t capacity) {
    return with_session(s, MCPT_ERROR_INTERNAL, [&](Session& session) {
        require(pixels != nullptr, "pixels is NULL");
        require_image(session);
        const std::vector<uint8_t> img = session.image_rgba8();
        require(capacity >= img.size(), "buffer too small: needs 4 * width * height bytes");
        std::memcpy(pixels, img.data(), img.size());
        return MCPT_OK;
    });
}

mcpt_status mcpt_session_write_image(mcpt_session s, const char* path) {
    return with_session(s, MCPT_ERROR_IO, [&](Session& session) {
        require(path != nullptr && *path, "path is NULL or empty");
        require_image(session);
        session.write_image(path);
        return MCPT_OK;
    });
}

mcpt_status mcpt_session_save_checkpoint(mcpt_session s, const char* path) {
    return with_session(s, MCPT_ERROR_IO, [&](Session& session) {
        require(path != nullptr && *path, "path is NULL or empty");
        require_image(session);
        session.save_checkpoint(path);
        return MCPT_OK;
    });
}

mcpt_status mcpt_session_resume_checkpoint(mcpt_session s, const char* path) {
    return with_session(s, MCPT_ERROR_IO, [&](Session& session) {
        require(path != nullptr && *path, "path is NULL or empty");
        require_scene(session);
        session.resume_checkpoint(path);
        return MCPT_OK;
    });
}

}  // extern "C"
