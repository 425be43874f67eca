#include "common/accel/cpu_trace.h"

#include <algorithm>

#include "common/error.h"
#include "common/gpu/integrator.h"
#include "common/gpu/ray_cast.h"

namespace mcpt {

namespace {
void check_stack(const GpuScene& s) {
    if (s.stack_size > KD_STACK_SIZE) {
        throw Error("tree too deep for the CPU traversal: stack of " +
                    std::to_string(s.stack_size) + " entries > " + std::to_string(KD_STACK_SIZE));
    }
}
}  // namespace

gpu::Hit cpu_trace(const GpuScene& s, const gpu::Ray& ray, bool any_hit) {
    check_stack(s);
    return gpu::trace_ray(&s.params, s.nodes.data(), s.leaf_indices.data(), s.triangles.data(),
                          s.spheres.data(), s.materials.data(), s.lights.data(),
                          s.attributes.data(), s.textures.data(), s.texels.data(), ray, any_hit);
}

gpu::Hit cpu_trace_tree(const KdTree& tree, const std::vector<gpu::GpuTriangle>& triangles,
                        const gpu::Ray& ray, bool any_hit, uint32_t scene_flags) {
    gpu::GpuParams p{};
    p.scene_flags = scene_flags | (tree.kind == TreeKind::Bvh ? SCENE_BVH : 0u);
    p.num_triangles = uint32_t(triangles.size());
    p.num_nodes = uint32_t(tree.nodes.size());
    p.scene_min_x = tree.bounds.min.x, p.scene_max_x = tree.bounds.max.x;
    p.scene_min_y = tree.bounds.min.y, p.scene_max_y = tree.bounds.max.y;
    p.scene_min_z = tree.bounds.min.z, p.scene_max_z = tree.bounds.max.z;
    return gpu::trace_ray(&p, tree.nodes.data(), tree.leaf_indices.data(), triangles.data(),
                          nullptr, nullptr, nullptr, nullptr, nullptr, nullptr, ray, any_hit);
}

gpu::Hit brute_force_hit(const std::vector<gpu::GpuTriangle>& triangles, const gpu::Ray& ray) {
    const gpu::WoopRay wr = gpu::woop_setup(ray.d);
    gpu::Hit best{};
    best.t = ray.tmax;
    best.prim = NO_HIT;
    for (uint32_t i = 0; i < triangles.size(); ++i) {
        gpu::Ray r = ray;
        r.tmax = best.t;
        const gpu::TriHit th = gpu::intersect_triangle(r, wr, triangles[i]);
        if (th.hit) best.t = th.t, best.b1 = th.b1, best.b2 = th.b2, best.prim = i;
    }
    return best;
}

gpu::Ray cpu_camera_ray(const GpuScene& s, const gpu::GpuParams& params, float fx, float fy) {
    return gpu::camera_ray(&params, s.nodes.data(), s.leaf_indices.data(), s.triangles.data(),
                           s.spheres.data(), s.materials.data(), s.lights.data(),
                           s.attributes.data(), s.textures.data(), s.texels.data(), fx, fy);
}

gpu::Ray cpu_cast_ray(const GpuScene& s, uint32_t i) {
    return gpu::cast_ray(&s.params, s.nodes.data(), s.leaf_indices.data(), s.triangles.data(),
                         s.spheres.data(), s.materials.data(), s.lights.data(), s.attributes.data(),
                         s.textures.data(), s.texels.data(), i);
}

gpu::PathResult cpu_trace_path(const GpuScene& s, const gpu::GpuParams& params, uint32_t pixel,
                               uint32_t sample_index) {
    check_stack(s);
    return gpu::trace_path(&params, s.nodes.data(), s.leaf_indices.data(), s.triangles.data(),
                           s.spheres.data(), s.materials.data(), s.lights.data(),
                           s.attributes.data(), s.textures.data(), s.texels.data(), pixel,
                           sample_index);
}

gpu::RayWork cpu_path_work(const GpuScene& s, const gpu::GpuParams& params, uint32_t pixel,
                           uint32_t sample_index, bool keep_visits) {
    gpu::RayWork work;
    work.keep_visits = keep_visits;
    gpu::path_work = &work;
    cpu_trace_path(s, params, pixel, sample_index);
    gpu::path_work = nullptr;
    return work;
}

std::vector<uint32_t> cpu_path_visits(const GpuScene& s, const gpu::GpuParams& params,
                                      uint32_t pixel, uint32_t sample_index) {
    return std::move(cpu_path_work(s, params, pixel, sample_index, true).visits_per_trace);
}

WarpLanes warp_lanes(const std::vector<std::vector<uint32_t>>& lanes) {
    size_t traces = 0;
    for (const auto& l : lanes) traces = std::max(traces, l.size());
    double done = 0, waited = 0, active = 0;
    for (size_t k = 0; k < traces; ++k) {
        uint32_t longest = 0, tracing = 0;
        for (const auto& l : lanes) {
            const uint32_t v = k < l.size() ? l[k] : 0u;
            done += v, longest = std::max(longest, v), tracing += k < l.size();
        }
        waited += longest, active += double(longest) * tracing;
    }
    WarpLanes w;
    if (waited > 0) w.busy = done / waited, w.active = active / waited;
    return w;
}

}  // namespace mcpt

namespace mcpt {

double lockstep_cost(const std::vector<std::vector<uint32_t>>& lanes, double shade) {
    // Iteration i: every lane's i-th ray, as long as the longest, then shading.
    size_t iterations = 0;
    for (const auto& l : lanes) iterations = std::max(iterations, l.size());
    double cost = 0;
    for (size_t i = 0; i < iterations; ++i) {
        uint32_t longest = 0;
        for (const auto& l : lanes) longest = std::max(longest, i < l.size() ? l[i] : 0u);
        cost += longest + shade;
    }
    return cost;
}

double walked_cost(const std::vector<std::vector<uint32_t>>& lanes, double shade, uint32_t steps,
                   bool vote) {
    // Each lane's ray (at) and the node steps it has left; a lane past its stream is done.
    const size_t n = lanes.size();
    std::vector<size_t> at(n, 0);
    std::vector<uint32_t> left(n, 0);
    for (size_t l = 0; l < n; ++l) left[l] = lanes[l].empty() ? 0u : lanes[l][0];
    double cost = 0;
    while (true) {
        uint32_t longest = 0, live = 0, waiting = 0;
        for (size_t l = 0; l < n; ++l)
            if (at[l] < lanes[l].size())
                live += 1, waiting += left[l] == 0, longest = std::max(longest, left[l]);
        if (live == 0) break;
        // Fixed: up to `steps` node steps. Vote: one step at a time while fewer than `steps`
        // lanes wait and some lane walks.
        uint32_t k = std::min(longest, steps);
        if (vote) k = waiting >= std::min(steps, live) ? 0u : std::min(longest, 1u);
        cost += k;
        for (size_t l = 0; l < n; ++l) left[l] -= std::min(left[l], k);
        if (vote && k > 0) continue;
        // The lanes whose ray ended shade and start their next.
        cost += shade;
        for (size_t l = 0; l < n; ++l)
            if (at[l] < lanes[l].size() && left[l] == 0 && ++at[l] < lanes[l].size())
                left[l] = lanes[l][at[l]];
    }
    return cost;
}

double grouped_walk_cost(const std::vector<std::vector<uint32_t>>& lanes, double shade,
                         uint32_t steps, bool regroup, double move, size_t warp) {
    const size_t kWarp = std::max<size_t>(1, warp);
    const size_t n = lanes.size();
    // Lane order[p] sits at place p (warp p / 32); each lane's ray (at) and its steps left.
    std::vector<size_t> order(n), at(n, 0);
    std::vector<uint32_t> left(n, 0);
    for (size_t l = 0; l < n; ++l) order[l] = l, left[l] = lanes[l].empty() ? 0u : lanes[l][0];
    const auto live = [&](size_t l) { return at[l] < lanes[l].size(); };
    double cost = 0;
    while (true) {
        // Walk: each warp as long as its longest ray, at most `steps`.
        bool any = false;
        for (size_t w = 0; w < n; w += kWarp) {
            uint32_t longest = 0;
            for (size_t p = w; p < std::min(n, w + kWarp); ++p)
                if (live(order[p])) any = true, longest = std::max(longest, left[order[p]]);
            const uint32_t k = std::min(longest, steps);
            cost += k;
            for (size_t p = w; p < std::min(n, w + kWarp); ++p)
                left[order[p]] -= std::min(left[order[p]], k);
        }
        if (!any) break;
        // Regroup: the lanes whose ray ended first, in place order.
        const auto ended = [&](size_t l) { return live(l) && left[l] == 0; };
        if (regroup) {
            std::stable_partition(order.begin(), order.end(), ended);
            cost += move * double((n + kWarp - 1) / kWarp);
        }
        // Shade: each warp holding a lane whose ray ended; those lanes start their next ray.
        for (size_t w = 0; w < n; w += kWarp) {
            bool shades = false;
            for (size_t p = w; p < std::min(n, w + kWarp); ++p) shades = shades || ended(order[p]);
            if (shades) cost += shade;
        }
        for (size_t l = 0; l < n; ++l)
            if (ended(l) && ++at[l] < lanes[l].size()) left[l] = lanes[l][at[l]];
    }
    return cost;
}

}  // namespace mcpt
