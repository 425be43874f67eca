// mcpt tree: build the scene's tree (k-d or BVH) and report its statistics (for the BVH its
// SAH cost) and the work per ray (triangle tests and node visits), measured with the shared
// traversal code on the CPU; for the BVH, a model of GPU warps over full paths (busy lanes,
// the walk against lock-step, work-groups regrouped against not: docs/traversal.md).
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <random>
#include <vector>

#include "app/commands.h"
#include "common/accel/cpu_trace.h"
#include "common/accel/wide_bvh.h"

namespace mcpt {

namespace {

void print_work(const char* what, const gpu::RayWork& w) {
    std::printf(
        "  %-34s %8.0f rays: %7.2f triangle tests/ray, %7.2f node visits/ray, "
        "%5.1f%% hit\n",
        what, w.rays, w.tests_per_ray(), w.visits_per_ray(), 100.0 * w.hits / w.rays);
}

}  // namespace

void run_tree(const TreeArgs& a) {
    Scene scene = load_scene_argument(a.scene);
    const KdTree tree = build_kdtree(scene.triangles, tree_options(a.tree, a.depth));
    const GpuScene g = pack_scene(scene, tree);
    std::printf("%s, %zu triangles, tree %s\n", a.scene.c_str(), scene.triangles.size(),
                a.tree.c_str());
    if (!scene.extensions.empty())
        std::printf("glTF extensions: %s\n", extension_list(scene).c_str());
    std::printf("%s", describe(tree.stats, scene.triangles.size(), tree.kind).c_str());
    const double tri_bytes = double(scene.triangles.size() * sizeof(gpu::GpuTriangle));
    std::printf("  bytes per triangle (tree + triangle data): %.1f\n",
                (double(tree.stats.bytes) + tri_bytes) /
                    double(std::max<size_t>(1, scene.triangles.size())));
    if (tree.kind == TreeKind::Bvh)
        std::printf("  SAH cost (a node visit as %g triangle tests, the root's area 1): %.2f\n",
                    kSimtCostModel.wide_node_visit,
                    bvh_sah_cost(tree, kSimtCostModel.wide_node_visit, 1.0));

    // Camera rays through a square grid of pixels.
    gpu::GpuParams p = g.params;
    const int side = std::max(1, int(std::sqrt(double(a.rays))));
    set_camera(p, scene.camera, side, side);
    gpu::RayWork camera, random_rays;
    for (int y = 0; y < side; ++y) {
        for (int x = 0; x < side; ++x) {
            const float fx = (x + 0.5f) / side * 2 - 1, fy = 1 - (y + 0.5f) / side * 2;
            camera.add(cpu_trace(g, cpu_camera_ray(g, p, fx, fy), false));
        }
    }
    // Random rays from points inside the bounds in uniform directions.
    std::mt19937 rng(1);
    std::uniform_real_distribution<float> u(0.f, 1.f);
    const Bounds b = tree.bounds;
    for (int i = 0; i < side * side; ++i) {
        gpu::Ray r;
        r.o = b.min + (b.max - b.min) * glm::vec3(u(rng), u(rng), u(rng));
        const float z = 1 - 2 * u(rng), phi = 6.2831853f * u(rng), s = std::sqrt(1 - z * z);
        r.d = {s * std::cos(phi), s * std::sin(phi), z};
        r.tmax = MCPT_FLT_MAX;
        random_rays.add(cpu_trace(g, r, false));
    }
    std::printf("work per ray (shared traversal on the CPU):\n");
    print_work("camera rays", camera);
    print_work("random rays from inside the bounds", random_rays);

    // A warp's view of full paths at 1024^2 (pixel = first pixel + invocation: a warp is 32
    // pixels of a row), the same sample in each lane, every trace as long as its longest ray.
    if (a.warps > 0) {
        const RenderOptions ro;
        gpu::GpuParams pp = g.params;
        set_camera(pp, scene.camera, 1024, 1024);
        pp.max_depth = ro.max_depth, pp.rr_depth = ro.rr_depth, pp.seed = 12345;
        const uint32_t warps_in_image = 1024u * 1024u / 32u;
        double busy = 0, active = 0, rays = 0, visits = 0;
        gpu::RayWork path_rays;
        for (int w = 0; w < a.warps; ++w) {
            const uint32_t first = uint32_t((uint64_t(w) * 2654435761u) % warps_in_image) * 32u;
            std::vector<std::vector<uint32_t>> lanes;
            for (uint32_t i = 0; i < 32; ++i) {
                gpu::RayWork work = cpu_path_work(g, pp, first + i, uint32_t(w), true);
                path_rays.add(work);
                lanes.push_back(std::move(work.visits_per_trace));
                rays += double(lanes.back().size());
                for (uint32_t v : lanes.back()) visits += v;
            }
            const WarpLanes wl = warp_lanes(lanes);
            busy += wl.busy, active += wl.active;
        }
        std::printf("  warps of 32 paths in lock-step, %d warps at 1024x1024: %.1f of 32 lanes "
                    "visit a node per step, %.1f still tracing (%.2f visits/ray, %.1f "
                    "rays/path)\n",
                    a.warps, busy / a.warps, active / a.warps, visits / std::max(1.0, rays),
                    rays / (32.0 * a.warps));
        print_work("rays of those paths", path_rays);
        // Each lane's stream of 8 samples (path regeneration): the walk's cost against
        // lock-step for a shading step of 2, 4 or 8 node steps (docs/traversal.md).
        const double shades[] = {2, 4, 8};
        const uint32_t steps[] = {1, 2, 4, 6, 8};
        double lock[3] = {}, walked[3][5] = {}, vote[3] = {};
        for (int w = 0; w < a.warps; ++w) {
            const uint32_t first = uint32_t((uint64_t(w) * 2654435761u) % warps_in_image) * 32u;
            std::vector<std::vector<uint32_t>> lanes(32);
            for (uint32_t i = 0; i < 32; ++i)
                for (uint32_t k = 0; k < 8; ++k) {
                    const auto v = cpu_path_visits(g, pp, first + i, uint32_t(w) * 8 + k);
                    lanes[i].insert(lanes[i].end(), v.begin(), v.end());
                }
            for (int si = 0; si < 3; ++si) {
                lock[si] += lockstep_cost(lanes, shades[si]);
                for (int k = 0; k < 5; ++k)
                    walked[si][k] += walked_cost(lanes, shades[si], steps[k]);
                vote[si] += walked_cost(lanes, shades[si], 16, true);
            }
        }
        std::printf(
            "  a warp's cost a sample of its 32 lanes, in node steps, shading costing 4: "
            "lock-step %.1f, walked 4 steps a pause %.1f\n",
            lock[1] / (8.0 * a.warps), walked[1][2] / (8.0 * a.warps));
        std::printf(
            "  walked (step_slot_walk) against lock-step, 8 samples a lane:\n"
            "    shading cost | walk steps 1     2     4     6     8 | vote at 16\n");
        for (int si = 0; si < 3; ++si) {
            std::printf("    %4.0f nodes   |          ", shades[si]);
            for (int k = 0; k < 5; ++k) std::printf(" %5.3f", walked[si][k] / lock[si]);
            std::printf(" | %5.3f\n", vote[si] / lock[si]);
        }
        // Work-groups of 64 lanes (two warps in step at each pause), walked 4 steps at a time:
        // regrouped at each pause (the lanes whose ray ended packed together) against each
        // lane keeping its warp, for an exchange costing 0, 2 or 8 node steps a warp.
        const double moves[] = {0, 2, 8};
        double kept[3] = {}, moved[3][3] = {};
        for (int w = 0; w < a.warps / 2; ++w) {
            const uint32_t first = uint32_t((uint64_t(w) * 2654435761u) % warps_in_image) * 32u;
            std::vector<std::vector<uint32_t>> lanes(64);
            for (uint32_t i = 0; i < 64; ++i)
                for (uint32_t k = 0; k < 8; ++k) {
                    const auto v = cpu_path_visits(g, pp, (first + i) % (1024u * 1024u),
                                                   uint32_t(w) * 8 + k);
                    lanes[i].insert(lanes[i].end(), v.begin(), v.end());
                }
            for (int si = 0; si < 3; ++si) {
                kept[si] += grouped_walk_cost(lanes, shades[si], 4, false);
                for (int m = 0; m < 3; ++m)
                    moved[si][m] += grouped_walk_cost(lanes, shades[si], 4, true, moves[m]);
            }
        }
        std::printf("  work-groups of 64 lanes walked 4 steps a pause, regrouped against not:\n"
                    "    shading cost | exchange 0     2     8 node steps a warp\n");
        for (int si = 0; si < 3; ++si) {
            std::printf("    %4.0f nodes   |         ", shades[si]);
            for (int m = 0; m < 3; ++m) std::printf(" %5.3f", moved[si][m] / kept[si]);
            std::printf("\n");
        }
    }
}

}  // namespace mcpt
