#include "opencl/cl_backend.h"

#include <CL/opencl.hpp>
#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <sstream>

#include "common/error.h"
#include "common/io/host_cpus.h"
#include "common/render/device_limits.h"
#include "common/render/device_registry.h"
#include "kPathtraceClSource.h"

namespace mcpt {

namespace {

std::string trim_cl_string(std::string s) {
    while (!s.empty() && (s.back() == '\0' || s.back() == ' ')) s.pop_back();
    return s;
}

struct ClDevice {
    cl::Platform platform;
    cl::Device device;
    DeviceInfo info;
};

std::vector<ClDevice> enumerate() {
    // One thread at a time: the ICD loader's first clGetPlatformIDs is not thread-safe (two
    // sessions opened at once, one of them found no platform).
    static std::mutex enumerating;
    std::lock_guard<std::mutex> hold(enumerating);
    std::vector<ClDevice> out;
    std::vector<cl::Platform> platforms;
    try {
        cl::Platform::get(&platforms);
    } catch (const cl::Error&) {
        return out;  // no ICD or no platform
    }
    for (const cl::Platform& pl : platforms) {
        std::vector<cl::Device> devices;
        try {
            pl.getDevices(CL_DEVICE_TYPE_ALL, &devices);
        } catch (const cl::Error&) {
            continue;
        }
        for (const cl::Device& d : devices) {
            ClDevice cd{pl, d, {}};
            DeviceInfo& i = cd.info;
            i.backend = "opencl";
            i.index = int(out.size());
            i.name = trim_cl_string(d.getInfo<CL_DEVICE_NAME>());
            i.platform = trim_cl_string(pl.getInfo<CL_PLATFORM_NAME>());
            const cl_device_type t = d.getInfo<CL_DEVICE_TYPE>();
            i.type = (t & CL_DEVICE_TYPE_GPU) ? "gpu" : (t & CL_DEVICE_TYPE_CPU) ? "cpu" : "other";
            i.limits = {
                {"version", trim_cl_string(d.getInfo<CL_DEVICE_VERSION>())},
                {"compute units", std::to_string(d.getInfo<CL_DEVICE_MAX_COMPUTE_UNITS>())},
                {"global memory", human_bytes(d.getInfo<CL_DEVICE_GLOBAL_MEM_SIZE>())},
                {"max allocation", human_bytes(d.getInfo<CL_DEVICE_MAX_MEM_ALLOC_SIZE>())},
                {"local memory", human_bytes(d.getInfo<CL_DEVICE_LOCAL_MEM_SIZE>())},
                {"max work-group size", std::to_string(d.getInfo<CL_DEVICE_MAX_WORK_GROUP_SIZE>())},
            };
            i.memory.max_buffer_bytes = d.getInfo<CL_DEVICE_MAX_MEM_ALLOC_SIZE>();
            i.memory.max_buffer_name = "CL_DEVICE_MAX_MEM_ALLOC_SIZE";
            i.memory.device_memory_bytes = d.getInfo<CL_DEVICE_GLOBAL_MEM_SIZE>();
            out.push_back(cd);
        }
    }
    return out;
}

class OpenClBackend final : public Backend {
  public:
    OpenClBackend(ClDevice dev, BackendOptions options)
        : dev_(std::move(dev)), options_(std::move(options)) {
        limit_buffers(dev_.info.memory, options_.max_buffer_bytes);
        context_ = cl::Context(dev_.device);
        queue_ = cl::CommandQueue(context_, dev_.device, CL_QUEUE_PROFILING_ENABLE);
        // Read-backs through pinned memory on GPUs ($MCPT_PINNED_READBACK=0 or 1 overrides;
        // tests take the path on CPU devices).
        const char* pinned = std::getenv("MCPT_PINNED_READBACK");
        pinned_read_back_ = pinned && (pinned == std::string("0") || pinned == std::string("1"))
                                ? pinned[0] == '1'
                                : dev_.info.type == "gpu";
    }

    ~OpenClBackend() override {
        if (!pinned_ptr_) return;
        try {
            queue_.enqueueUnmapMemObject(pinned_, pinned_ptr_);
            queue_.finish();
        } catch (const cl::Error&) {
            // A stopped device: nothing left to give back.
        }
    }

    std::string description() const override {
        return "opencl: " + dev_.info.name + " (" + dev_.info.platform + ")";
    }
    const DeviceInfo& device() const override { return dev_.info; }
    double compile_seconds() const override { return compile_seconds_; }
    uint32_t compiled_features() const override { return built_features_; }
    double device_seconds() const override { return device_seconds_; }
    uint32_t max_bounces_per_dispatch() const override { return 1u << 20; }
    std::string build_settings() const override { return built_options_; }

    std::string layout() const override {
        return std::to_string(BINDING_COUNT) + " buffer arguments, workgroup " +
               std::to_string(local_) + window_note(accum_shape_) +
               (pinned_bytes_ > 0 ? ", pinned read-back" : "");
    }

    void load(const GpuScene& scene, int width, int height, bool exact_sums) override {
        if ((scene.params.scene_flags & SCENE_RAY_QUERY) != 0u)
            throw Error(description() + ": ray queries (--tree rayquery) are Vulkan only");
        build(scene.stack_size, compile_features(options_, scene));
        // Check every buffer against the device limits before allocating.
        check_device_limits(scene, width, height, dev_.info, description());
        const AccumLayout layout =
            accum_layout_for(scene, width, height, dev_.info.memory, exact_sums);
        const uint64_t accum_bytes = layout.bytes;
        sums_floats_ = size_t(layout.sums_bytes() / 4);
        counter_offset_ = size_t(layout.pending_offset());
        accum_shape_ = layout;
        // Upload (empty arrays get one dummy element: OpenCL has no empty buffers).
        params_ = make_buffer(&scene.params, sizeof(gpu::GpuParams), CL_MEM_READ_ONLY);
        tree_ = upload(tree_buffer(scene));
        tris_ = upload(triangle_buffer(scene));
        shading_ = upload(shading_buffer(scene));
        accum_ = cl::Buffer(context_, CL_MEM_READ_WRITE, accum_bytes);
        // The sums' read-back memory now, not in the first read-back's time.
        if (pinned_read_back_) reserve_pinned(sums_floats_ * 4);
        // Kernel arguments in BINDING_* order.
        const cl::Buffer* args[] = {&params_, &tree_, &tris_, &shading_, &accum_};
        static_assert(sizeof(args) / sizeof(args[0]) == BINDING_COUNT, "one argument per binding");
        for (cl_uint i = 0; i < BINDING_COUNT; ++i) kernel_.setArg(i, *args[i]);
    }

    uint32_t dispatch(const gpu::GpuParams& p) override {
        try {
            if (!first_dispatch_logged_) {
                // PoCL compiles the kernel for its work-group size at the first launch: what
                // a build costs is this and the build together ($MCPT_COMPILE_LOG).
                first_dispatch_logged_ = true;
                const auto t0 = std::chrono::steady_clock::now();
                const uint32_t active = run_dispatch(p);
                log_compile(
                    "opencl-first-dispatch",
                    std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(),
                    built_options_);
                return active;
            }
            return run_dispatch(p);
        } catch (const cl::Error& e) {
            stopped(e.err(), e.what());
        }
    }

    void write_plan(const std::vector<uint32_t>& words) override {
        if (words.size() * 4 > accum_shape_.plan_bytes())
            throw Error("opencl: a sample plan for more slots than the buffer holds");
        try {
            queue_.enqueueWriteBuffer(accum_, CL_TRUE, accum_shape_.plan_offset(), words.size() * 4,
                                      words.data());
        } catch (const cl::Error& e) {
            stopped(e.err(), e.what());
        }
    }

    const AccumLayout& accum_shape() const override { return accum_shape_; }

    void read_exact(std::vector<uint32_t>& out, uint32_t first, uint32_t count) override {
        if (uint64_t(first) + count > accum_shape_.exact_pixels)
            throw Error("opencl: exact sums of pixels the buffer does not hold");
        const uint64_t per_pixel = EXACT_VEC4_PER_PIXEL * 16;
        out.resize(size_t(count) * EXACT_VEC4_PER_PIXEL * 4);
        read_back(accum_shape_.exact_offset() + first * per_pixel, count * per_pixel, out.data());
    }

    void read_accum(std::vector<float>& out, uint32_t pixels) override {
        // The sums only; the path state stays on the device.
        const size_t per_pixel = ACCUM_VEC4_PER_PIXEL * 4;
        out.resize(pixels == 0 ? sums_floats_ : std::min(sums_floats_, size_t(pixels) * per_pixel));
        read_back(0, out.size() * 4, out.data());
    }

  private:
    // Reads `bytes` of the sums buffer from `offset` into `to`. A GPU's read into pageable
    // memory goes through the driver's own staging copy: it reads into pinned memory of its
    // own (allocated once, mapped for good) and copies out on the host's threads instead.
    void read_back(size_t offset, size_t bytes, void* to) {
        try {
            if (!pinned_read_back_ || !reserve_pinned(bytes)) {
                queue_.enqueueReadBuffer(accum_, CL_TRUE, offset, bytes, to);
                return;
            }
            queue_.enqueueReadBuffer(accum_, CL_TRUE, offset, bytes, pinned_ptr_);
            copy_on_threads(to, pinned_ptr_, bytes);
        } catch (const cl::Error& e) {
            stopped(e.err(), e.what());
        }
    }

    // read_back()'s pinned memory, at least `bytes` of it. False where the driver
    // has none to give: read-backs then go through its pageable path, as before.
    bool reserve_pinned(size_t bytes) {
        if (pinned_bytes_ >= bytes) return true;
        if (pinned_refused_) return false;
        try {
            if (pinned_ptr_) queue_.enqueueUnmapMemObject(pinned_, pinned_ptr_);
            pinned_ptr_ = nullptr, pinned_bytes_ = 0, pinned_ = cl::Buffer();
            pinned_ = cl::Buffer(context_, CL_MEM_ALLOC_HOST_PTR | CL_MEM_READ_WRITE, bytes);
            pinned_ptr_ =
                queue_.enqueueMapBuffer(pinned_, CL_TRUE, CL_MAP_READ | CL_MAP_WRITE, 0, bytes);
        } catch (const cl::Error&) {
            pinned_ptr_ = nullptr, pinned_bytes_ = 0, pinned_ = cl::Buffer();
            pinned_refused_ = true;  // not asked again
            return false;
        }
        pinned_bytes_ = bytes;
        return true;
    }

    // The error for a command that failed while the device worked: OpenCL has no "device
    // lost"; drivers report a killed or faulted kernel as CL_OUT_OF_RESOURCES (NVIDIA) or an
    // execution-status error, and the queue is unusable afterwards.
    [[noreturn]] void stopped(cl_int err, const char* call) const {
        const std::string what = std::string(call) + " failed: OpenCL error " + std::to_string(err);
        if (err == CL_OUT_OF_RESOURCES || err == CL_OUT_OF_HOST_MEMORY ||
            err == CL_MEM_OBJECT_ALLOCATION_FAILURE || err == CL_INVALID_COMMAND_QUEUE ||
            err == CL_EXEC_STATUS_ERROR_FOR_EVENTS_IN_WAIT_LIST) {
            throw DeviceLost(what + " on " + description() +
                             ": the device stopped (a kernel killed by a watchdog or a fault, "
                             "or out of resources)");
        }
        throw Error(what + " on " + description());
    }

    uint32_t run_dispatch(const gpu::GpuParams& p) {
        if (p.pixel_count == 0) return 0;
        queue_.enqueueWriteBuffer(params_, CL_FALSE, 0, sizeof(p), &p);
        const cl_uint zero = 0;
        queue_.enqueueFillBuffer(accum_, zero, counter_offset_, sizeof(zero));
        const size_t global = (p.pixel_count + local_ - 1) / local_ * local_;
        // Profiling only: $MCPT_DUMP_DISPATCH=DIR[:N] writes a dispatch (default N 60) as
        // scripts/ptx-replay replays it under Nsight Compute.
        // (from dispatch N on, the first as large as any before: a pass's first dispatch, past
        // the first pass's small tiles).
        max_global_ = std::max(max_global_, global);
        if (dump_at_ != 0) dump_sizes_.push_back(global);
        const bool dump =
            dump_at_ != 0 && ++dispatch_count_ >= dump_at_ && !dumped_ && global == max_global_;
        dumped_ = dumped_ || dump;
        if (dump) dump_dispatch(global, "before");
        cl::Event done;
        queue_.enqueueNDRangeKernel(kernel_, cl::NullRange, cl::NDRange(global),
                                    cl::NDRange(local_), nullptr, &done);
        queue_.finish();
        // Kernel time from the profiling event (nanoseconds).
        const cl_ulong t0 = done.getProfilingInfo<CL_PROFILING_COMMAND_START>();
        const cl_ulong t1 = done.getProfilingInfo<CL_PROFILING_COMMAND_END>();
        if (t1 > t0) device_seconds_ += double(t1 - t0) * 1e-9;
        cl_uint active = 0;
        queue_.enqueueReadBuffer(accum_, CL_TRUE, counter_offset_, sizeof(active), &active);
        if (dump) dump_dispatch(global, "after");
        if (options_.lose_device_after != 0 && ++dispatches_ >= options_.lose_device_after)
            throw cl::Error(CL_OUT_OF_RESOURCES, "clFinish (injected by lose_device_after)");
        return active;
    }

    void build(uint32_t stack_size, uint32_t features) {
        std::string opts = "-cl-std=CL1.2 -DKD_STACK_SIZE=" + std::to_string(stack_size) +
                           "u -DMCPT_FEATURES=" + std::to_string(features) + "u";
        if (options_.fast_math) opts += " -cl-fast-relaxed-math";
        if (dev_.info.type == "gpu") opts += " -DMCPT_TRIANGLE_WORDS";  // scene_access.h
        if (dev_.info.type == "cpu") opts += " -DMCPT_KD_LEAF_LOOP";    // traverse.h
        if (dev_.info.type == "cpu") opts += " -DMCPT_BVH_VECTOR";      // traverse_bvh.h
        if (dev_.info.type == "cpu") opts += " -DMCPT_SAMPLER_VECTOR";  // sampler.h
        if (dev_.info.type == "cpu") opts += " -DMCPT_OUT_OF_LINE";     // platform.h
        opts += " -DMCPT_KD_MAILBOX";                                   // traverse.h
        // NVIDIA's compiler takes inline PTX (sampler.h: one instruction for a bit reversal).
        // Left alone it gives the kernel 109-157 registers (its Vulkan driver: 96-128); capped
        // by kernel (nvidia_register_cap) it runs 9-43% faster on the H100. Denormals flushed to
        // zero: +7% on the materials scene, -1 to -4% on the others, all closer to Vulkan's speed
        // (docs/benchmarks.md); lang.h also takes GLSL's normalize and length there.
        const uint32_t walk = walk_steps(dev_.info, features, false, stack_size - 1);
        if (dev_.info.platform.find("NVIDIA") != std::string::npos) {
            opts += " -DMCPT_NVIDIA_OPENCL -cl-denorms-are-zero";
            if (const uint32_t cap = nvidia_register_cap(features, walk); cap != 0)
                opts += " -cl-nv-maxrregcount=" + std::to_string(cap);
        }
        const KdSteps steps = kd_steps(dev_.info);
        if (steps.nodes != 1 || steps.triangles != 1)
            opts += " -DKD_NODE_STEPS=" + std::to_string(steps.nodes) +
                    "u -DKD_TRI_STEPS=" + std::to_string(steps.triangles) + "u";
        if (steps.overlap == 0) opts += " -DKD_OVERLAP=0u";
        if (trace_sites(dev_.info, features, false, stack_size - 1) == 1)
            opts += " -DMCPT_TRACE_SITES=1u";
        if (walk != 0) opts += " -DMCPT_WALK_STEPS=" + std::to_string(walk) + "u";
        if (options_.env_strategy != 0)
            opts += " -DMCPT_ENV_STRATEGY=" + std::to_string(options_.env_strategy) + "u";
        if (!options_.extra_defines.empty()) opts += " " + options_.extra_defines;
        if (program_() != nullptr && opts == built_options_) return;
        const auto t0 = std::chrono::steady_clock::now();
        program_ = cl::Program(context_, std::string(kPathtraceClSource));
        try {
            program_.build({dev_.device}, opts.c_str());
        } catch (const cl::Error&) {
            const std::string log = program_.getBuildInfo<CL_PROGRAM_BUILD_LOG>(dev_.device);
            throw Error("OpenCL kernel build failed on " + description() + " with options '" +
                        opts + "':\n" + log);
        }
        kernel_ = cl::Kernel(program_, "pathtrace");
        compile_seconds_ =
            std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        built_options_ = opts;
        built_features_ = features & FEATURE_BITS;
        first_dispatch_logged_ = false;
        log_compile("opencl", compile_seconds_, opts);
        // Work-group size within the kernel's and device's limits.
        const size_t kmax = kernel_.getWorkGroupInfo<CL_KERNEL_WORK_GROUP_SIZE>(dev_.device);
        local_ = std::max<size_t>(1, std::min<size_t>(WORKGROUP_SIZE, kmax));
    }

    cl::Buffer make_buffer(const void* data, size_t bytes, cl_mem_flags flags) {
        return cl::Buffer(context_, flags | CL_MEM_COPY_HOST_PTR, bytes, const_cast<void*>(data));
    }
    template <class T>
    cl::Buffer upload(const std::vector<T>& v) {
        if (v.empty()) {
            const T dummy{};
            return make_buffer(&dummy, sizeof(T), CL_MEM_READ_ONLY);
        }
        return make_buffer(v.data(), v.size() * sizeof(T), CL_MEM_READ_ONLY);
    }

    ClDevice dev_;
    BackendOptions options_;
    cl::Context context_;
    cl::CommandQueue queue_;
    cl::Program program_;
    cl::Kernel kernel_;
    std::string built_options_;
    bool first_dispatch_logged_ = true;  // until a build
    cl::Buffer params_, tree_, tris_, shading_, accum_;
    size_t sums_floats_ = 0, counter_offset_ = 0;
    cl::Buffer pinned_;  // read_back()'s staging memory (GPUs), mapped at pinned_ptr_
    void* pinned_ptr_ = nullptr;
    size_t pinned_bytes_ = 0;
    bool pinned_read_back_ = false, pinned_refused_ = false;
    AccumLayout accum_shape_;
    size_t local_ = WORKGROUP_SIZE;
    double compile_seconds_ = 0;
    uint32_t built_features_ = 0;
    double device_seconds_ = 0;
    uint32_t dispatches_ = 0;  // counted for options_.lose_device_after
    uint64_t dispatch_count_ = 0;
    size_t max_global_ = 0;
    std::vector<size_t> dump_sizes_;
    bool dumped_ = false;
    uint64_t dump_at_ = dump_dispatch_number();  // $MCPT_DUMP_DISPATCH; 0: none

    // NVIDIA's register cap: 56, none for the BVH walk, or $MCPT_NV_MAXRREGCOUNT for
    // measurements (0: none). (H100, 1024², M rays/s: walked 4 steps at a time under the cap
    // of 56 the bunny ran at 1,486 and the 871k dragon at 1,135; under 80, 2,408 and 1,588;
    // uncapped 2,443 and 1,800. Walked whole, capped: 2,207 and 1,783; uncapped 2,199 and 1,652.)
    static uint64_t dump_dispatch_number() {
        const char* e = std::getenv("MCPT_DUMP_DISPATCH");
        if (!e || !*e) return 0;
        const char* colon = std::strrchr(e, ':');
        return colon ? std::max(1ull, std::strtoull(colon + 1, nullptr, 10)) : 60;
    }
    // The program (PTX on NVIDIA), the launch size and every buffer argument, before the
    // dispatch, and the accumulation buffer after it (the replay compares against it).
    void dump_dispatch(size_t global, const char* when) {
        std::string dir = std::getenv("MCPT_DUMP_DISPATCH");
        if (const size_t colon = dir.rfind(':'); colon != std::string::npos) dir.resize(colon);
        std::filesystem::create_directories(dir);
        const auto write = [&](const std::string& name, const void* data, size_t bytes) {
            std::ofstream f(dir + "/" + name, std::ios::binary);
            f.write(static_cast<const char*>(data), std::streamsize(bytes));
            if (!f) throw Error("cannot write " + dir + "/" + name);
        };
        queue_.finish();
        const cl::Buffer* args[] = {&params_, &tree_, &tris_, &shading_, &accum_};
        const bool before = std::string(when) == "before";
        for (int i = before ? 0 : BINDING_COUNT - 1; i < int(BINDING_COUNT); ++i) {
            std::vector<char> bytes(args[i]->getInfo<CL_MEM_SIZE>());
            queue_.enqueueReadBuffer(*args[i], CL_TRUE, 0, bytes.size(), bytes.data());
            write("arg" + std::to_string(i) + (before ? "" : ".after") + ".bin", bytes.data(),
                  bytes.size());
        }
        if (!before) return;
        // The sizes of the dispatches up to this one.
        std::string sizes;
        for (size_t g : dump_sizes_) sizes += std::to_string(g) + "\n";
        write("sizes.txt", sizes.data(), sizes.size());
        const std::vector<std::vector<unsigned char>> binaries =
            program_.getInfo<CL_PROGRAM_BINARIES>();
        std::string ptx(binaries.at(0).begin(), binaries.at(0).end());
        while (!ptx.empty() && ptx.back() == '\0') ptx.pop_back();
        write("kernel.ptx", ptx.data(), ptx.size());
        const std::string launch = "pathtrace " + std::to_string(global) + " " +
                                   std::to_string(local_) + " " + std::to_string(BINDING_COUNT) +
                                   "\n" + built_options_ + "\n";
        write("launch.txt", launch.data(), launch.size());
    }
};

}  // namespace

std::vector<DeviceInfo> list_opencl_devices() {
    std::vector<DeviceInfo> out;
    for (const ClDevice& d : enumerate()) out.push_back(d.info);
    return out;
}

const char* opencl_kernel_source() {
    return kPathtraceClSource;
}

std::unique_ptr<Backend> make_opencl_backend(const BackendOptions& options) {
    if (!options.limits.empty() && options.limits != "device") {
        throw Error("limits profile '" + options.limits +
                    "' is Vulkan only (OpenCL has no per-stage buffer limits)");
    }
    std::vector<ClDevice> devices = enumerate();
    if (devices.empty()) {
        throw Error("no OpenCL device found (install an ICD such as pocl-opencl-icd)");
    }
    std::vector<DeviceInfo> infos;
    for (const ClDevice& d : devices) infos.push_back(d.info);
    const ClDevice* chosen = &devices[select_device(infos, options.device, "opencl")];
    try {
        return std::make_unique<OpenClBackend>(*chosen, options);
    } catch (const cl::Error& e) {
        throw Error(std::string("OpenCL error ") + std::to_string(e.err()) + " in " + e.what());
    }
}

}  // namespace mcpt
