// Fuzz target: glTF 2.0 / GLB bytes through what mcpt_session_load_memory() runs (parse,
// bounds checks, validation, no file system: no base folder) and then the host half of
// mcpt_session_commit() (the k-d tree that auto picks, the packed device layout, the limits
// check against a phone's memory limits at 64x64). A clear mcpt::Error is the expected
// outcome for most inputs; anything else (a crash, a sanitizer report, another exception, a
// hang, memory beyond libFuzzer's limit) is a defect.
#include <cstddef>
#include <cstdint>

#include "common/error.h"
#include "common/render/device_limits.h"
#include "common/render/prepare.h"
#include "common/scene/scene_load.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    mcpt::Scene scene;
    try {
        scene = mcpt::load_scene_memory(data, size, "fuzz");
    } catch (const mcpt::Error&) {
        return 0;  // refused with a message: the loader did its job
    }
    mcpt::DeviceInfo device;
    device.backend = "vulkan";
    device.name = "fuzz";
    device.memory.max_buffer_bytes = uint64_t(1) << 27;  // Vulkan 1.1's maxStorageBufferRange
    device.memory.max_buffer_name = "maxStorageBufferRange";
    device.memory.device_memory_bytes = uint64_t(1) << 30;
    mcpt::TreeOptions tree = mcpt::tree_options("auto");
    tree.threads = 1;
    try {
        (void)mcpt::prepare_scene(scene, device, tree, 64, 64);
    } catch (const mcpt::Error&) {
        // Limits refused it (too many triangles for the phone's buffers): also a clear error.
    }
    return 0;
}
