// The device traversal and path tracer compiled for the CPU: the same functions the kernels
// run, used by tests (against brute force; the rays the device oracle tests cast), `mcpt tree`
// and `mcpt bench` (work per ray); and the models of a GPU warp (and a work-group of warps)
// over the paths' rays that `mcpt tree` prints.
// Only the plain data of gpu/ray_types.h is visible here, not the device dialect's macros.
#pragma once
#include <vector>

#include "common/accel/kdtree.h"
#include "common/gpu/ray_types.h"
#include "common/render/gpu_scene.h"

namespace mcpt {

// Closest (or any) hit of the ray in the packed scene, through the shared trace_ray().
gpu::Hit cpu_trace(const GpuScene& scene, const gpu::Ray& ray, bool any_hit);

// The closest (or any) hit among `triangles` alone through `tree` (built over them), with the
// shared trace_ray(); status reports a stack overflow instead of throwing. scene_flags:
// SCENE_KD_OVERLAP traverses with overlapped steps, as the device builds do.
gpu::Hit cpu_trace_tree(const KdTree& tree, const std::vector<gpu::GpuTriangle>& triangles,
                        const gpu::Ray& ray, bool any_hit = false, uint32_t scene_flags = 0);

// The oracle it is checked against (tests, fuzzing): every triangle in index order with the
// same triangle test, no tree (ties: the lower index); prim is NO_HIT when the ray misses
// them all. t, prim and the barycentrics b1, b2 of the hit.
gpu::Hit brute_force_hit(const std::vector<gpu::GpuTriangle>& triangles, const gpu::Ray& ray);

// The camera ray through (fx, fy) in [-1, 1]^2 of params' camera, through the shared
// camera_ray().
gpu::Ray cpu_camera_ray(const GpuScene& scene, const gpu::GpuParams& params, float fx, float fy);

// Ray i of the device traversals' oracle tests (GpuParams.ray_cast), through the shared
// cast_ray().
gpu::Ray cpu_cast_ray(const GpuScene& scene, uint32_t i);

// One path sample through the shared trace_path(); params carries camera and depth settings.
gpu::PathResult cpu_trace_path(const GpuScene& scene, const gpu::GpuParams& params, uint32_t pixel,
                               uint32_t sample_index);

// The traversal work of every ray (camera, bounce, shadow) of that same path sample; with
// `keep_visits`, each ray's node visits too (RayWork::visits_per_trace).
gpu::RayWork cpu_path_work(const GpuScene& scene, const gpu::GpuParams& params, uint32_t pixel,
                           uint32_t sample_index, bool keep_visits = false);

// The node visits of each ray of that path sample in the order traced (camera ray, then each
// vertex's shadow and bounce rays): a GPU warp walks 32 such sequences in lock-step.
std::vector<uint32_t> cpu_path_visits(const GpuScene& scene, const gpu::GpuParams& params,
                                      uint32_t pixel, uint32_t sample_index);

// A model of a GPU warp in the traversal: `lanes` neighbouring pixels' paths in lock-step, one
// trace after another; the warp spends each trace as long as its longest ray. Per node-visit
// step of the warp, on average: the lanes visiting a node (busy) and the lanes whose path is
// still tracing (active; the rest ended their paths).
struct WarpLanes {
    double busy = 0, active = 0;
};
WarpLanes warp_lanes(const std::vector<std::vector<uint32_t>>& lanes);

// The warp's cost, in node steps, of tracing each lane's stream of rays (its paths one after
// another, as path regeneration runs them), shading costing `shade` node steps: lock-step, as
// step_slot runs (each iteration every lane's next ray, as long as the longest, then
// shading), or walked, as step_slot_walk runs (up to `steps` node steps, then the lanes whose
// ray ended shade; with `vote`, node steps until `steps` lanes wait, as a warp vote would).
double lockstep_cost(const std::vector<std::vector<uint32_t>>& lanes, double shade);
double walked_cost(const std::vector<std::vector<uint32_t>>& lanes, double shade, uint32_t steps,
                   bool vote = false);

// The walk over a work-group of several warps of `warp` lanes, its warps in step at each pause: every warp holding a lane walks up to `steps` node steps (as long as its
// longest ray, at most `steps`), then every warp holding a lane whose ray ended shades. With
// `regroup`, the lanes are regrouped at each pause, the ones whose ray ended packed into the
// first warps (they shade together, and their fresh rays walk together), each warp paying
// `move` node steps for the exchange; without, each lane keeps its warp.
double grouped_walk_cost(const std::vector<std::vector<uint32_t>>& lanes, double shade,
                         uint32_t steps, bool regroup, double move = 0, size_t warp = 32);

}  // namespace mcpt
