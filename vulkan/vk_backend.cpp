#include "vulkan/vk_backend.h"

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <cstring>

#include "common/error.h"
#include "common/io/host_cpus.h"
#include "common/render/device_limits.h"
#include "common/render/device_registry.h"
#include "pathtrace_rayquery_comp_spv.h"
#include "pathtrace_storage_comp_spv.h"
#include "pathtrace_texels_comp_spv.h"
#include "vulkan/vk_accel.h"
#include "vulkan/vk_context.h"
#include "vulkan/vk_device.h"
#include "vulkan/vk_limits_profile.h"
#include "vulkan/vk_ray_pipeline.h"

namespace mcpt {

using vk::Buffer;

// The texel buffers' formats: two 32-bit words per texel for a k-d tree (a node), four for a
// BVH (a node is fourteen), the triangles (two and a half texels each) and the shading buffer
// (spheres, materials and lights are whole 16-byte texels).
constexpr VkFormat kPairFormat = VK_FORMAT_R32G32_UINT;
constexpr VkFormat kQuadFormat = VK_FORMAT_R32G32B32A32_UINT;

struct VulkanBackend::Impl {
    std::shared_ptr<vk::Instance> instance;
    size_t messages_before = 0;  // the shared instance's count when this backend began
    vk::PhysicalDevice pd;
    std::unique_ptr<vk::Device> dev;
    VkQueryPool timer = VK_NULL_HANDLE;      // two timestamps per dispatch, if the queue has them
    VkShaderModule module = VK_NULL_HANDLE;  // scene in storage buffers
    VkShaderModule texel_module = VK_NULL_HANDLE;  // scene in texel buffers
    VkDescriptorSetLayout set_layout = VK_NULL_HANDLE;
    VkPipelineLayout pipeline_layout = VK_NULL_HANDLE;
    VkDescriptorPool descriptor_pool = VK_NULL_HANDLE;
    VkDescriptorSet set = VK_NULL_HANDLE;
    // Devices with ray queries: the module that traces through them. Those with either ray
    // queries or the ray-tracing pipeline: the descriptor set of both (the eight bindings
    // above and the top-level acceleration structure).
    VkShaderModule rq_module = VK_NULL_HANDLE;
    VkDescriptorSetLayout tlas_set_layout = VK_NULL_HANDLE;
    VkPipelineLayout tlas_pipeline_layout = VK_NULL_HANDLE;
    VkDescriptorPool tlas_pool = VK_NULL_HANDLE;
    VkDescriptorSet tlas_set = VK_NULL_HANDLE;
    VkPipelineCache cache = VK_NULL_HANDLE;
    VkPipeline pipeline = VK_NULL_HANDLE;  // the compute pipeline (not with scene_rt)
    vk::RayPipeline ray_pipeline;          // the ray-tracing pipeline (scene_rt)
    std::string cache_path;
    std::vector<char> cache_data;  // as last read or written

    // Scene resources, replaced by each load().
    Buffer params, tree, tris, shading, accum, readback;
    VkBufferView tree_view = VK_NULL_HANDLE, tris_view = VK_NULL_HANDLE,
                 shading_view = VK_NULL_HANDLE;
    bool scene_texels = false;  // the pipeline reads the views, not the storage buffers
    bool scene_rq = false;      // the pipeline traces through ray queries (SCENE_RAY_QUERY)
    bool scene_rt = false;      // the ray-tracing pipeline traces (SCENE_RAY_PIPELINE)
    vk::SceneAccel accel;       // the scene's acceleration structures, where either
    uint32_t pixels = 0;
    uint64_t counter_offset = 0;  // bytes: the active-slot counter in the accumulation buffer
    AccumLayout accum_shape;      // what the accumulation buffer holds

    // Pipeline specialization, dispatch limit, timings.
    uint32_t local = WORKGROUP_SIZE;
    uint32_t max_groups = 1;
    uint32_t built_stack = 0, built_features = 0;
    bool built_texels = false, built_rq = false, built_rt = false;
    uint32_t built_walk = 0;
    bool first_dispatch_logged = true;  // until a build
    std::string built_settings;         // the specialization constants, "NAME=value ..."
    std::string statistics;  // the driver's, of the compute pipeline ($MCPT_VULKAN_STATISTICS)
    BackendOptions options;
    uint32_t dispatches = 0;  // counted for options.lose_device_after
    double compile_seconds = 0;
    double gpu_seconds = 0;

    ~Impl() { destroy(); }

    std::string description() const {
        return "vulkan: " + pd.info.name + " (" + pd.info.platform + ")" +
               (pd.limits_profile == "phone" ? ", phone limits" : "");
    }

    void init(std::shared_ptr<vk::Instance> inst, vk::PhysicalDevice chosen) {
        instance = std::move(inst);
        messages_before = instance->messages();
        pd = std::move(chosen);
        const VkPhysicalDeviceLimits& l = pd.props.limits;
        vk::check_layout(l, description());
        dev = std::make_unique<vk::Device>(*instance, pd, description());
        const vk::DeviceFns& f = dev->fn();
        const VkDevice device = dev->handle();

        // Timestamp pool, if the queue family has timestamps.
        if (pd.timestamp_valid_bits > 0) {
            VkQueryPoolCreateInfo qpi{};
            qpi.sType = VK_STRUCTURE_TYPE_QUERY_POOL_CREATE_INFO;
            qpi.queryType = VK_QUERY_TYPE_TIMESTAMP;
            qpi.queryCount = 2;
            VK_CHECK(f.vkCreateQueryPool, device, &qpi, nullptr, &timer);
        }

        // Shader modules from the embedded SPIR-V.
        VkShaderModuleCreateInfo si{};
        si.sType = VK_STRUCTURE_TYPE_SHADER_MODULE_CREATE_INFO;
        si.codeSize = sizeof(kPathtraceSpirv);
        si.pCode = kPathtraceSpirv;
        VK_CHECK(f.vkCreateShaderModule, device, &si, nullptr, &module);
        si.codeSize = sizeof(kPathtraceTexelsSpirv);
        si.pCode = kPathtraceTexelsSpirv;
        VK_CHECK(f.vkCreateShaderModule, device, &si, nullptr, &texel_module);

        // The texel views' formats (required of every Vulkan device).
        for (VkFormat format : {kPairFormat, kQuadFormat}) {
            VkFormatProperties fp{};
            instance->fn().vkGetPhysicalDeviceFormatProperties(pd.handle, format, &fp);
            if (!(fp.bufferFeatures & VK_FORMAT_FEATURE_UNIFORM_TEXEL_BUFFER_BIT))
                throw Error(description() + ": no uniform texel buffers of VkFormat " +
                            std::to_string(format));
        }

        // The descriptor set: the params uniform buffer, storage buffers and texel buffers at
        // the BINDING_* slots.
        make_descriptor_set(VK_BINDING_COUNT, VK_SHADER_STAGE_COMPUTE_BIT, set_layout,
                            pipeline_layout, descriptor_pool, set);

        if (pd.accel()) init_driver_tracing();

        // Pipeline cache, seeded from disk when the file matches this device and driver.
        cache_path = vk::pipeline_cache_path(pd.props);
        cache_data = vk::read_pipeline_cache(cache_path, pd.props);
        VkPipelineCacheCreateInfo ci{};
        ci.sType = VK_STRUCTURE_TYPE_PIPELINE_CACHE_CREATE_INFO;
        ci.initialDataSize = cache_data.size();
        ci.pInitialData = cache_data.empty() ? nullptr : cache_data.data();
        VK_CHECK(f.vkCreatePipelineCache, device, &ci, nullptr, &cache);

        // Workgroup size within the device's limits; dispatch size limit.
        local = vk::workgroup_size(l);
        max_groups =
            uint32_t(vk::env_limit("MCPT_VULKAN_MAX_GROUP_COUNT", l.maxComputeWorkGroupCount[0]));
    }

    // A descriptor set layout of `count` bindings (descriptor_type() of each slot) for these
    // stages, its pipeline layout, a pool for one set, and the set.
    void make_descriptor_set(uint32_t count, VkShaderStageFlags stages,
                             VkDescriptorSetLayout& layout, VkPipelineLayout& pipeline_layout_out,
                             VkDescriptorPool& pool, VkDescriptorSet& out) {
        const vk::DeviceFns& f = dev->fn();
        const VkDevice device = dev->handle();
        VkDescriptorSetLayoutBinding bindings[VK_RAY_QUERY_BINDING_COUNT]{};
        for (uint32_t b = 0; b < count; ++b) {
            bindings[b].binding = b;
            bindings[b].descriptorType = descriptor_type(b);
            bindings[b].descriptorCount = 1;
            bindings[b].stageFlags = stages;
        }
        VkDescriptorSetLayoutCreateInfo li{};
        li.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO;
        li.bindingCount = count;
        li.pBindings = bindings;
        VK_CHECK(f.vkCreateDescriptorSetLayout, device, &li, nullptr, &layout);
        VkPipelineLayoutCreateInfo pli{};
        pli.sType = VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO;
        pli.setLayoutCount = 1;
        pli.pSetLayouts = &layout;
        VK_CHECK(f.vkCreatePipelineLayout, device, &pli, nullptr, &pipeline_layout_out);
        const VkDescriptorPoolSize sizes[] = {
            {VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER, 1},
            {VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, STORAGE_BUFFER_COUNT},
            {VK_DESCRIPTOR_TYPE_UNIFORM_TEXEL_BUFFER, TEXEL_BUFFER_COUNT},
            {VK_DESCRIPTOR_TYPE_ACCELERATION_STRUCTURE_KHR, 1}};
        VkDescriptorPoolCreateInfo dpi{};
        dpi.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO;
        dpi.maxSets = 1;
        dpi.poolSizeCount = count > BINDING_TLAS ? 4 : 3;  // the structure: the driver's only
        dpi.pPoolSizes = sizes;
        VK_CHECK(f.vkCreateDescriptorPool, device, &dpi, nullptr, &pool);
        VkDescriptorSetAllocateInfo dsi{};
        dsi.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO;
        dsi.descriptorPool = pool;
        dsi.descriptorSetCount = 1;
        dsi.pSetLayouts = &layout;
        VK_CHECK(f.vkAllocateDescriptorSets, device, &dsi, &out);
    }

    // The ray-query module, and the descriptor set of the driver's tracing: the eight
    // bindings of init() and the top-level acceleration structure at BINDING_TLAS, for the
    // compute stage and, where the device has the pipeline, its ray-tracing stages.
    void init_driver_tracing() {
        if (pd.ray_query) {
            VkShaderModuleCreateInfo si{};
            si.sType = VK_STRUCTURE_TYPE_SHADER_MODULE_CREATE_INFO;
            si.codeSize = sizeof(kPathtraceRayQuerySpirv);
            si.pCode = kPathtraceRayQuerySpirv;
            VK_CHECK(dev->fn().vkCreateShaderModule, dev->handle(), &si, nullptr, &rq_module);
        }
        VkShaderStageFlags stages = VK_SHADER_STAGE_COMPUTE_BIT;
        if (pd.ray_pipeline) {
            stages |= VK_SHADER_STAGE_RAYGEN_BIT_KHR | VK_SHADER_STAGE_MISS_BIT_KHR |
                      VK_SHADER_STAGE_CLOSEST_HIT_BIT_KHR | VK_SHADER_STAGE_ANY_HIT_BIT_KHR |
                      VK_SHADER_STAGE_INTERSECTION_BIT_KHR;
        }
        make_descriptor_set(VK_RAY_QUERY_BINDING_COUNT, stages, tlas_set_layout,
                            tlas_pipeline_layout, tlas_pool, tlas_set);
    }

    void destroy() {
        if (dev) {
            const vk::DeviceFns& f = dev->fn();
            const VkDevice device = dev->handle();
            f.vkDeviceWaitIdle(device);
            release_scene();
            ray_pipeline.release();
            if (pipeline) f.vkDestroyPipeline(device, pipeline, nullptr);
            if (cache) f.vkDestroyPipelineCache(device, cache, nullptr);
            if (descriptor_pool) f.vkDestroyDescriptorPool(device, descriptor_pool, nullptr);
            if (tlas_pool) f.vkDestroyDescriptorPool(device, tlas_pool, nullptr);
            if (tlas_pipeline_layout)
                f.vkDestroyPipelineLayout(device, tlas_pipeline_layout, nullptr);
            if (tlas_set_layout) f.vkDestroyDescriptorSetLayout(device, tlas_set_layout, nullptr);
            if (rq_module) f.vkDestroyShaderModule(device, rq_module, nullptr);
            if (pipeline_layout) f.vkDestroyPipelineLayout(device, pipeline_layout, nullptr);
            if (set_layout) f.vkDestroyDescriptorSetLayout(device, set_layout, nullptr);
            if (module) f.vkDestroyShaderModule(device, module, nullptr);
            if (texel_module) f.vkDestroyShaderModule(device, texel_module, nullptr);
            if (timer) f.vkDestroyQueryPool(device, timer, nullptr);
            dev.reset();
        }
        instance.reset();
    }

    template <class T>
    Buffer upload(const std::vector<T>& v, VkBufferUsageFlags more_usage = 0) {
        // Empty arrays get a dummy texel: Vulkan has no empty buffers.
        const uint64_t dummy[2] = {};
        return v.empty() ? dev->upload(dummy, sizeof(dummy), more_usage)
                         : dev->upload(v.data(), v.size() * sizeof(T), more_usage);
    }

    static VkDescriptorType descriptor_type(uint32_t binding) {
        if (binding == BINDING_PARAMS) return VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER;
        if (binding == BINDING_TLAS) return VK_DESCRIPTOR_TYPE_ACCELERATION_STRUCTURE_KHR;
        if (binding >= BINDING_COUNT) return VK_DESCRIPTOR_TYPE_UNIFORM_TEXEL_BUFFER;
        return VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
    }

    // Whether the pipeline should read the tree, triangles and shading data through texel
    // buffers (options.scene_reads, else $MCPT_VULKAN_SCENE_READS, else on CPU devices).
    bool prefer_texels() const {
        std::string reads = options.scene_reads;
        if (reads.empty()) {
            const char* e = std::getenv("MCPT_VULKAN_SCENE_READS");
            reads = e ? e : "";
        }
        if (reads.empty()) return pd.props.deviceType == VK_PHYSICAL_DEVICE_TYPE_CPU;
        if (reads != "texel" && reads != "storage")
            throw Error("vulkan: scene reads '" + reads + "': expected texel or storage");
        return reads == "texel";
    }

    // A view of `words` words of `b` (padded to whole texels), `per_texel` words per texel,
    // within the device's texel limit; whether all of them fit.
    bool make_view(const Buffer& b, size_t words, uint32_t per_texel, VkBufferView& view) {
        const uint64_t texels = std::max<uint64_t>(1, words / per_texel);
        const uint64_t max_texels = pd.props.limits.maxTexelBufferElements;
        VkBufferViewCreateInfo vi{};
        vi.sType = VK_STRUCTURE_TYPE_BUFFER_VIEW_CREATE_INFO;
        vi.buffer = b.buffer;
        vi.format = per_texel == 2 ? kPairFormat : kQuadFormat;
        vi.offset = 0;
        vi.range = std::min(texels, max_texels) * per_texel * 4;
        VK_CHECK(dev->fn().vkCreateBufferView, dev->handle(), &vi, nullptr, &view);
        return texels <= max_texels;
    }

    void release_scene() {
        for (VkBufferView* v : {&tree_view, &tris_view, &shading_view}) {
            if (*v) dev->fn().vkDestroyBufferView(dev->handle(), *v, nullptr);
            *v = VK_NULL_HANDLE;
        }
        for (Buffer* b : {&params, &tree, &tris, &shading, &accum, &readback}) dev->free_buffer(*b);
        accel.release();
        scene_rq = scene_rt = false;
        pixels = 0;
    }

    void build(uint32_t stack_size, uint32_t features, bool texels, bool rq, bool rt) {
        // (The walk's count, read from the environment, changes the constants too.)
        const uint32_t walk = walk_steps(pd.info, features, rt, stack_size - 1);
        if ((pipeline || ray_pipeline.handle()) && stack_size == built_stack &&
            features == built_features && texels == built_texels && rq == built_rq &&
            rt == built_rt && walk == built_walk)
            return;
        const vk::DeviceFns& f = dev->fn();
        if (pipeline) f.vkDestroyPipeline(dev->handle(), pipeline, nullptr);
        pipeline = VK_NULL_HANDLE;
        if (!rt) ray_pipeline.release();  // else build() replaces it, keeping its modules
        const auto t0 = std::chrono::steady_clock::now();
        // Specialization: id 0 = KD_STACK_SIZE, id 1 = local_size_x, id 2 = MCPT_FEATURES,
        // ids 3, 4 and 5 = KD_NODE_STEPS, KD_TRI_STEPS and KD_OVERLAP, id 6 = the environment
        // strategy (tests), id 7 = MCPT_TRACE_SITES, id 8 = MCPT_WALK_STEPS.
        const KdSteps steps = kd_steps(pd.info);
        constexpr uint32_t kSpecs = 9;
        const uint32_t values[kSpecs] = {stack_size,
                                         local,
                                         features,
                                         steps.nodes,
                                         steps.triangles,
                                         steps.overlap,
                                         options.env_strategy,
                                         trace_sites(pd.info, features, rt, stack_size - 1),
                                         walk};
        static const char* const names[kSpecs] = {
            "KD_STACK_SIZE",     "local_size_x",     "MCPT_FEATURES",
            "KD_NODE_STEPS",     "KD_TRI_STEPS",     "KD_OVERLAP",
            "MCPT_ENV_STRATEGY", "MCPT_TRACE_SITES", "MCPT_WALK_STEPS"};
        VkSpecializationMapEntry entries[kSpecs];
        built_settings.clear();
        for (uint32_t i = 0; i < kSpecs; ++i) {
            entries[i] = {i, 4 * i, 4};
            built_settings +=
                std::string(i ? " " : "") + names[i] + "=" + std::to_string(values[i]);
        }
        VkSpecializationInfo spec{};
        spec.mapEntryCount = kSpecs;
        spec.pMapEntries = entries;
        spec.dataSize = sizeof(values);
        spec.pData = values;
        // A cold build (compile nonce) bypasses the pipeline cache and leaves it as it is.
        const bool cold = options.compile_nonce != 0;
        if (rt) {
            ray_pipeline.build(*dev, pd, tlas_pipeline_layout, spec, cold ? VK_NULL_HANDLE : cache);
        } else {
            VkComputePipelineCreateInfo ci{};
            ci.sType = VK_STRUCTURE_TYPE_COMPUTE_PIPELINE_CREATE_INFO;
            ci.stage.sType = VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO;
            ci.stage.stage = VK_SHADER_STAGE_COMPUTE_BIT;
            ci.stage.module = rq ? rq_module : texels ? texel_module : module;
            ci.stage.pName = "main";
            ci.stage.pSpecializationInfo = &spec;
            ci.layout = rq ? tlas_pipeline_layout : pipeline_layout;
            if (dev->statistics()) ci.flags |= VK_PIPELINE_CREATE_CAPTURE_STATISTICS_BIT_KHR;
            VK_CHECK(f.vkCreateComputePipelines, dev->handle(), cold ? VK_NULL_HANDLE : cache, 1,
                     &ci, nullptr, &pipeline);
        }
        statistics = dev->pipeline_statistics(pipeline);
        compile_seconds =
            std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        built_stack = stack_size;
        built_features = features;
        built_texels = texels;
        built_rq = rq;
        built_rt = rt;
        built_walk = walk;
        first_dispatch_logged = false;
        log_compile("vulkan", compile_seconds,
                    built_settings + (rt       ? " raypipeline"
                                      : rq     ? " rayquery"
                                      : texels ? " texels"
                                               : " storage"));

        // Save the cache if the driver's data changed.
        if (cold) return;
        size_t size = 0;
        if (f.vkGetPipelineCacheData(dev->handle(), cache, &size, nullptr) != VK_SUCCESS) return;
        std::vector<char> data(size);
        if (f.vkGetPipelineCacheData(dev->handle(), cache, &size, data.data()) != VK_SUCCESS)
            return;
        data.resize(size);
        if (data == cache_data) return;
        vk::write_pipeline_cache(cache_path, data);
        cache_data = std::move(data);
    }

    // ---- Backend

    void load(const GpuScene& scene, int width, int height, bool exact_sums) {
        // Check every buffer against the device limits before allocating or compiling.
        const uint64_t npix = uint64_t(width) * uint64_t(height);
        pd.info.memory = vk::memory_limits(pd);
        limit_buffers(pd.info.memory, options.max_buffer_bytes);
        check_device_limits(scene, width, height, pd.info, description());
        const AccumLayout layout =
            accum_layout_for(scene, width, height, pd.info.memory, exact_sums);
        const uint64_t accum_bytes = layout.bytes;
        dev->wait_idle();
        release_scene();

        // Upload; the tree, triangles and shading data also as texel buffers (padded to whole
        // texels). The accumulation buffer is device-local, zeroed, read back directly when
        // host-visible and through a readback buffer otherwise.
        params = dev->create_buffer(sizeof(gpu::GpuParams), VK_BUFFER_USAGE_UNIFORM_BUFFER_BIT,
                                    vk::kHostMemory, VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT);
        std::memcpy(params.mapped, &scene.params, sizeof(gpu::GpuParams));
        std::vector<uint32_t> tree_words = tree_buffer(scene);
        std::vector<uint32_t> tri_words = triangle_buffer(scene);
        std::vector<uint32_t> shading_words = shading_buffer(scene);
        // The tree's texels: k-d nodes as word pairs, BVH nodes as quads (scene_access.h).
        const uint32_t tree_texel = (scene.params.scene_flags & SCENE_BVH) != 0u ? 4u : 2u;
        tree_words.resize((tree_words.size() + tree_texel - 1) / tree_texel * tree_texel);
        tri_words.resize((tri_words.size() + 3) / 4 * 4);
        shading_words.resize((shading_words.size() + 3) / 4 * 4);
        const VkBufferUsageFlags texel = VK_BUFFER_USAGE_UNIFORM_TEXEL_BUFFER_BIT;
        tree = upload(tree_words, texel);
        tris = upload(tri_words, texel);
        shading = upload(shading_words, texel);
        // Every view is made (the descriptor set binds all three), so `&`, not `&&`.
        const bool fits = make_view(tree, tree_words.size(), tree_texel, tree_view) &
                          make_view(tris, tri_words.size(), 4, tris_view) &
                          make_view(shading, shading_words.size(), 4, shading_view);
        // The driver's tracing: the scene's acceleration structures, read by the
        // storage-buffer form.
        scene_rq = (scene.params.scene_flags & SCENE_RAY_QUERY) != 0u;
        scene_rt = (scene.params.scene_flags & SCENE_RAY_PIPELINE) != 0u;
        if (scene_rq && !pd.ray_query) {
            throw Error(description() +
                        ": --tree rayquery needs ray queries, and this device has " +
                        pd.ray_query_note + "; use --tree auto or bvh");
        }
        if (scene_rt && !pd.ray_pipeline) {
            throw Error(description() +
                        ": --tree raypipeline needs the ray-tracing pipeline, and this device "
                        "has " +
                        pd.ray_pipeline_note + "; use --tree auto or bvh");
        }
        if (scene_rq || scene_rt) {
            std::vector<bool> cut_out(scene.triangles.size());
            for (size_t i = 0; i < cut_out.size(); ++i) {
                const uint32_t m = scene.triangles[i].material;
                cut_out[i] = m < scene.materials.size() && scene.materials[m].alpha_cutoff > 0.f;
            }
            accel.build(*dev, pd, scene.triangles, scene.spheres, cut_out, options.accel_fault);
        }
        scene_texels = !scene_rq && !scene_rt && prefer_texels() && fits;

        // Pipeline for this scene's stack depth and features, and how it reads the scene.
        build(scene.stack_size, compile_features(options, scene), scene_texels, scene_rq, scene_rt);
        accum = dev->create_buffer(accum_bytes,
                                   VK_BUFFER_USAGE_STORAGE_BUFFER_BIT |
                                       VK_BUFFER_USAGE_TRANSFER_SRC_BIT |
                                       VK_BUFFER_USAGE_TRANSFER_DST_BIT,
                                   0, VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT);
        if (!accum.mapped) {
            // The sums (read_accum), or the pending word (dispatch), never the path state.
            // Also the staging buffer of the sample plan (smaller than the sums).
            readback = dev->create_buffer(
                std::max(layout.sums_bytes(), layout.plan_bytes()),
                VK_BUFFER_USAGE_TRANSFER_DST_BIT | VK_BUFFER_USAGE_TRANSFER_SRC_BIT,
                vk::kHostMemory, VK_MEMORY_PROPERTY_HOST_CACHED_BIT);
        }
        dev->begin_commands();
        dev->fn().vkCmdFillBuffer(dev->cmd(), accum.buffer, 0, VK_WHOLE_SIZE, 0);
        dev->barrier(
            VK_PIPELINE_STAGE_TRANSFER_BIT, VK_ACCESS_TRANSFER_WRITE_BIT,
            dev->shader_stages() | VK_PIPELINE_STAGE_HOST_BIT,
            VK_ACCESS_SHADER_READ_BIT | VK_ACCESS_SHADER_WRITE_BIT | VK_ACCESS_HOST_READ_BIT);
        dev->submit_and_wait();
        pixels = uint32_t(npix);
        counter_offset = layout.pending_offset();
        accum_shape = layout;

        // Descriptor set: every buffer and view at its BINDING_* slot.
        const Buffer* by_slot[BINDING_COUNT] = {};
        by_slot[BINDING_PARAMS] = &params;
        by_slot[BINDING_TREE] = &tree;
        by_slot[BINDING_TRIANGLES] = &tris;
        by_slot[BINDING_SHADING] = &shading;
        by_slot[BINDING_ACCUM] = &accum;
        VkBufferView views[VK_BINDING_COUNT] = {};
        views[BINDING_TREE_TEXELS] = tree_view;
        views[BINDING_TRIANGLE_TEXELS] = tris_view;
        views[BINDING_SHADING_TEXELS] = shading_view;
        VkDescriptorBufferInfo infos[BINDING_COUNT];
        VkWriteDescriptorSet writes[VK_RAY_QUERY_BINDING_COUNT]{};
        const bool tlas = scene_rq || scene_rt;
        const uint32_t count = tlas ? VK_RAY_QUERY_BINDING_COUNT : VK_BINDING_COUNT;
        const VkAccelerationStructureKHR top = accel.top();
        VkWriteDescriptorSetAccelerationStructureKHR top_write{};
        top_write.sType = VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET_ACCELERATION_STRUCTURE_KHR;
        top_write.accelerationStructureCount = 1;
        top_write.pAccelerationStructures = &top;
        for (uint32_t b = 0; b < count; ++b) {
            writes[b].sType = VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET;
            writes[b].dstSet = tlas ? tlas_set : set;
            writes[b].dstBinding = b;
            writes[b].descriptorCount = 1;
            writes[b].descriptorType = descriptor_type(b);
            if (b < BINDING_COUNT) {
                infos[b] = {by_slot[b]->buffer, 0, VK_WHOLE_SIZE};
                writes[b].pBufferInfo = &infos[b];
            } else if (b == BINDING_TLAS) {
                writes[b].pNext = &top_write;
            } else {
                writes[b].pTexelBufferView = &views[b];
            }
        }
        dev->fn().vkUpdateDescriptorSets(dev->handle(), count, writes, 0, nullptr);
    }

    uint32_t dispatch(const gpu::GpuParams& p) {
        if ((!pipeline && !ray_pipeline.handle()) || pixels == 0)
            throw Error("vulkan: dispatch() before load()");
        if (uint64_t(p.pixel_offset) + p.pixel_count > pixels) {
            throw Error("vulkan: dispatch of pixels [" + std::to_string(p.pixel_offset) + ", " +
                        std::to_string(uint64_t(p.pixel_offset) + p.pixel_count) +
                        ") outside the " + std::to_string(pixels) + " loaded");
        }
        if (p.pixel_count == 0) return 0;
        // More workgroups (or launches) than the device allows in one dispatch: consecutive
        // dispatches over pixel ranges (vkCmdDispatchBase gave wrong pixels on NVIDIA's driver).
        const uint64_t max_pixels = scene_rt ? std::min<uint64_t>(vk::RayPipeline::max_launch(pd),
                                                                  uint64_t(max_groups) * local)
                                             : uint64_t(max_groups) * local;
        if (p.pixel_count > max_pixels) {
            uint32_t active = 0;
            for (uint64_t done = 0; done < p.pixel_count; done += max_pixels) {
                gpu::GpuParams part = p;
                part.pixel_offset = uint32_t(p.pixel_offset + done);
                part.pixel_count = uint32_t(std::min<uint64_t>(max_pixels, p.pixel_count - done));
                active += dispatch(part);
            }
            return active;
        }
        // Parameters: the previous dispatch has finished, so the mapped UBO is free.
        std::memcpy(params.mapped, &p, sizeof(p));

        // Record: order after the previous dispatch, time, dispatch.
        const vk::DeviceFns& f = dev->fn();
        const VkCommandBuffer cmd = dev->cmd();
        dev->begin_commands();
        // The active-slot counter (after the sums and the path state) starts at zero.
        f.vkCmdFillBuffer(cmd, accum.buffer, counter_offset, 16, 0);
        dev->barrier(dev->shader_stages() | VK_PIPELINE_STAGE_TRANSFER_BIT,
                     VK_ACCESS_SHADER_WRITE_BIT | VK_ACCESS_TRANSFER_WRITE_BIT,
                     dev->shader_stages(), VK_ACCESS_SHADER_READ_BIT | VK_ACCESS_SHADER_WRITE_BIT);
        if (timer) {
            f.vkCmdResetQueryPool(cmd, timer, 0, 2);
            f.vkCmdWriteTimestamp(cmd, VK_PIPELINE_STAGE_TOP_OF_PIPE_BIT, timer, 0);
        }
        const VkPipelineBindPoint point =
            scene_rt ? VK_PIPELINE_BIND_POINT_RAY_TRACING_KHR : VK_PIPELINE_BIND_POINT_COMPUTE;
        const bool tlas = scene_rq || scene_rt;
        f.vkCmdBindPipeline(cmd, point, scene_rt ? ray_pipeline.handle() : pipeline);
        f.vkCmdBindDescriptorSets(cmd, point, tlas ? tlas_pipeline_layout : pipeline_layout, 0, 1,
                                  tlas ? &tlas_set : &set, 0, nullptr);
        if (scene_rt)
            ray_pipeline.trace(p.pixel_count);
        else
            f.vkCmdDispatch(cmd, (p.pixel_count + local - 1) / local, 1, 1);
        if (timer) f.vkCmdWriteTimestamp(cmd, VK_PIPELINE_STAGE_BOTTOM_OF_PIPE_BIT, timer, 1);
        dev->barrier(dev->shader_stages(), VK_ACCESS_SHADER_WRITE_BIT,
                     VK_PIPELINE_STAGE_HOST_BIT | VK_PIPELINE_STAGE_TRANSFER_BIT,
                     VK_ACCESS_HOST_READ_BIT | VK_ACCESS_TRANSFER_READ_BIT);
        if (!accum.mapped) {
            // The counter into the readback buffer.
            const VkBufferCopy region{counter_offset, 0, 4};
            f.vkCmdCopyBuffer(cmd, accum.buffer, readback.buffer, 1, &region);
            dev->barrier(VK_PIPELINE_STAGE_TRANSFER_BIT, VK_ACCESS_TRANSFER_WRITE_BIT,
                         VK_PIPELINE_STAGE_HOST_BIT, VK_ACCESS_HOST_READ_BIT);
        }

        // Submit, wait, add the device time.
        dev->submit_and_wait();
        if (options.lose_device_after != 0 && ++dispatches >= options.lose_device_after)
            vk::check(VK_ERROR_DEVICE_LOST, "vkWaitForFences (injected by lose_device_after)");
        if (timer) {
            uint64_t t[2] = {0, 0};
            VK_CHECK(f.vkGetQueryPoolResults, dev->handle(), timer, 0, 2, sizeof(t), t,
                     sizeof(uint64_t), VK_QUERY_RESULT_64_BIT | VK_QUERY_RESULT_WAIT_BIT);
            const uint64_t mask =
                pd.timestamp_valid_bits >= 64 ? ~0ull : (1ull << pd.timestamp_valid_bits) - 1;
            gpu_seconds +=
                double((t[1] - t[0]) & mask) * double(pd.props.limits.timestampPeriod) * 1e-9;
        }
        uint32_t active = 0;
        std::memcpy(&active,
                    accum.mapped ? static_cast<const char*>(accum.mapped) + counter_offset
                                 : readback.mapped,
                    4);
        return active;
    }

    void write_plan(const std::vector<uint32_t>& words) {
        if (pixels == 0) throw Error("vulkan: write_plan() before load()");
        const uint64_t bytes = words.size() * 4;
        if (bytes > accum_shape.plan_bytes())
            throw Error("vulkan: a sample plan for more slots than the buffer holds");
        if (bytes == 0) return;
        if (accum.mapped) {
            // Host-coherent: visible to the next submission.
            std::memcpy(static_cast<char*>(accum.mapped) + accum_shape.plan_offset(), words.data(),
                        size_t(bytes));
            return;
        }
        // Not host-visible: through the readback buffer.
        std::memcpy(readback.mapped, words.data(), size_t(bytes));
        dev->begin_commands();
        const VkBufferCopy region{0, accum_shape.plan_offset(), bytes};
        dev->fn().vkCmdCopyBuffer(dev->cmd(), readback.buffer, accum.buffer, 1, &region);
        dev->barrier(VK_PIPELINE_STAGE_TRANSFER_BIT, VK_ACCESS_TRANSFER_WRITE_BIT,
                     dev->shader_stages(), VK_ACCESS_SHADER_READ_BIT);
        dev->submit_and_wait();
    }

    void read_exact(std::vector<uint32_t>& out, uint32_t first, uint32_t count) {
        if (uint64_t(first) + count > accum_shape.exact_pixels)
            throw Error("vulkan: exact sums of pixels the buffer does not hold");
        const uint64_t per_pixel = EXACT_VEC4_PER_PIXEL * 16;
        out.resize(size_t(count) * EXACT_VEC4_PER_PIXEL * 4);
        const uint64_t offset = accum_shape.exact_offset() + first * per_pixel;
        if (accum.mapped) {
            std::memcpy(out.data(), static_cast<const char*>(accum.mapped) + offset,
                        size_t(count * per_pixel));
            return;
        }
        // Not host-visible: through the readback buffer, as many pixels at a time as it holds.
        const uint64_t step = std::max<uint64_t>(1, readback.size / per_pixel);
        for (uint64_t done = 0; done < count; done += step) {
            const uint64_t bytes = std::min<uint64_t>(step, count - done) * per_pixel;
            dev->begin_commands();
            const VkBufferCopy region{offset + done * per_pixel, 0, bytes};
            dev->fn().vkCmdCopyBuffer(dev->cmd(), accum.buffer, readback.buffer, 1, &region);
            dev->barrier(VK_PIPELINE_STAGE_TRANSFER_BIT, VK_ACCESS_TRANSFER_WRITE_BIT,
                         VK_PIPELINE_STAGE_HOST_BIT, VK_ACCESS_HOST_READ_BIT);
            dev->submit_and_wait();
            std::memcpy(reinterpret_cast<char*>(out.data()) + done * per_pixel, readback.mapped,
                        size_t(bytes));
        }
    }

    void read_accum(std::vector<float>& out, uint32_t count) {
        if (pixels == 0) throw Error("vulkan: read_accum() before load()");
        // The sums only (the path state after them stays on the device).
        const uint64_t all = accum_shape.sum_pixels;
        const uint64_t bytes =
            (count == 0 ? all : std::min<uint64_t>(count, all)) * ACCUM_VEC4_PER_PIXEL * 16;
        out.resize(size_t(bytes / 4));
        if (accum.mapped) {
            copy_on_threads(out.data(), accum.mapped, size_t(bytes));
            return;
        }
        // Not host-visible: copy into the readback buffer first.
        dev->begin_commands();
        const VkBufferCopy region{0, 0, bytes};
        dev->fn().vkCmdCopyBuffer(dev->cmd(), accum.buffer, readback.buffer, 1, &region);
        dev->barrier(VK_PIPELINE_STAGE_TRANSFER_BIT, VK_ACCESS_TRANSFER_WRITE_BIT,
                     VK_PIPELINE_STAGE_HOST_BIT, VK_ACCESS_HOST_READ_BIT);
        dev->submit_and_wait();
        copy_on_threads(out.data(), readback.mapped, size_t(bytes));
    }
};

// ---- VulkanBackend: forwards to Impl

VulkanBackend::VulkanBackend(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
VulkanBackend::~VulkanBackend() = default;
std::string VulkanBackend::description() const {
    return impl_->description();
}
const DeviceInfo& VulkanBackend::device() const {
    return impl_->pd.info;
}
void VulkanBackend::load(const GpuScene& scene, int width, int height, bool exact_sums) {
    impl_->load(scene, width, height, exact_sums);
}
const AccumLayout& VulkanBackend::accum_shape() const {
    return impl_->accum_shape;
}
uint32_t VulkanBackend::dispatch(const gpu::GpuParams& params) {
    if (impl_->first_dispatch_logged) return impl_->dispatch(params);
    // lavapipe compiles the pipeline's code at its first dispatch: what a build costs is this
    // and the build together ($MCPT_COMPILE_LOG).
    impl_->first_dispatch_logged = true;
    const auto t0 = std::chrono::steady_clock::now();
    const uint32_t active = impl_->dispatch(params);
    log_compile("vulkan-first-dispatch",
                std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(),
                impl_->built_settings);
    return active;
}
void VulkanBackend::write_plan(const std::vector<uint32_t>& words) {
    impl_->write_plan(words);
}
void VulkanBackend::read_accum(std::vector<float>& out, uint32_t pixels) {
    impl_->read_accum(out, pixels);
}
void VulkanBackend::read_exact(std::vector<uint32_t>& out, uint32_t first, uint32_t count) {
    impl_->read_exact(out, first, count);
}
double VulkanBackend::compile_seconds() const {
    return impl_->compile_seconds;
}
uint32_t VulkanBackend::max_bounces_per_dispatch() const {
    // llvmpipe (lavapipe) ends every loop of an invocation once 65,535 iterations have run
    // in all of them together (gallivm's LP_MAX_TGSI_LOOP_ITERATIONS): 16 bounces, each a few
    // hundred traversal steps at most, stay far below it.
    return impl_->pd.props.deviceType == VK_PHYSICAL_DEVICE_TYPE_CPU ? 64u : (1u << 20);
}
uint32_t VulkanBackend::compiled_features() const {
    return impl_->built_features & FEATURE_BITS;
}
bool VulkanBackend::has_gpu_timer() const {
    return impl_->timer != VK_NULL_HANDLE;
}
double VulkanBackend::gpu_seconds() const {
    return impl_->gpu_seconds;
}
size_t VulkanBackend::validation_messages() const {
    return impl_->instance->messages() - impl_->messages_before;
}
std::string VulkanBackend::build_settings() const {
    return impl_->built_settings;
}
Backend::DeviceBuild VulkanBackend::device_build() const {
    const vk::AccelStats& s = impl_->accel.stats();
    return {s.build_seconds, s.bytes};
}
std::string VulkanBackend::layout() const {
    return vk::layout_line(impl_->pd.props.limits) +
           (impl_->scene_texels ? ", scene read as texel buffers" : "") +
           (impl_->scene_rq ? ", ray queries, " + impl_->accel.describe() : "") +
           (impl_->scene_rt ? ", ray-tracing pipeline, " + impl_->accel.describe() : "") +
           window_note(impl_->accum_shape) + statistics_note();
}
// What $MCPT_VULKAN_STATISTICS=1 asked of the driver: its statistics of the compute pipeline,
// or why there are none.
std::string VulkanBackend::statistics_note() const {
    if (!vk::pipeline_statistics_wanted()) return "";
    if (!impl_->statistics.empty()) return "; the driver's statistics: " + impl_->statistics;
    if (impl_->scene_rt) return "; no driver statistics (the ray-tracing pipeline: not asked)";
    if (!impl_->pd.pipeline_statistics)
        return std::string("; no driver statistics (") + vk::kPipelineStatisticsExtension +
               " absent)";
    return "; no driver statistics (none reported)";
}
uint32_t VulkanBackend::local_size() const {
    return impl_->local;
}

std::vector<DeviceInfo> list_vulkan_devices() {
    std::vector<DeviceInfo> out;
    try {
        for (const vk::PhysicalDevice& d : vk::shared_instance(false)->devices())
            out.push_back(d.info);
    } catch (const Error&) {
        // No loader, no ICD or no device: an empty list.
    }
    return out;
}

std::unique_ptr<Backend> make_vulkan_backend(const BackendOptions& options) {
    if (options.fast_math) {
        throw Error(
            "--fast-math is OpenCL only: the Vulkan shader is SPIR-V compiled at build "
            "time");
    }
    if (!options.extra_defines.empty()) {
        throw Error("extra defines (" + options.extra_defines +
                    ") are OpenCL only: the Vulkan shader is SPIR-V compiled at build time");
    }
    std::shared_ptr<vk::Instance> instance = vk::shared_instance(vk::validation_requested());
    std::vector<vk::PhysicalDevice> devices = instance->devices(options.limits);
    if (devices.empty()) throw Error(vk::kNoDeviceMessage);
    std::vector<DeviceInfo> infos;
    for (const vk::PhysicalDevice& d : devices) infos.push_back(d.info);
    const vk::PhysicalDevice* chosen = &devices[select_device(infos, options.device, "vulkan")];
    // Vulkan 1.1 and a compute queue are all the shader needs.
    if (chosen->props.apiVersion < VK_API_VERSION_1_1) {
        throw Error("Vulkan device " + chosen->info.name + " supports only Vulkan " +
                    vk::version_string(chosen->props.apiVersion) + "; mcpt needs 1.1");
    }
    if (chosen->queue_family == UINT32_MAX)
        throw Error("Vulkan device " + chosen->info.name + " has no compute queue");
    auto impl = std::make_unique<VulkanBackend::Impl>();
    impl->options = options;
    impl->init(std::move(instance), *chosen);
    return std::make_unique<VulkanBackend>(std::move(impl));
}

}  // namespace mcpt
