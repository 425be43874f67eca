// Fuzz target: the k-d tree builders and the BVH builder on arbitrary triangle soups (NaN, Inf, huge, denormal
// and degenerate triangles included: the bytes are the floats), then the shared device
// traversal (gpu::trace_ray, the code both kernels run) against brute force with the same
// triangle test, on soups whose coordinates are finite and within 2^-10..2^20 in size (the
// range the tracer promises results in). The first bytes pick the tree kind, the depth limit
// and the leaf size. BVH hits must equal brute force bit for bit (ties included).
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <vector>

#include "common/accel/cpu_trace.h"
#include "common/accel/kdtree.h"
#include "common/accel/wide_bvh.h"
#include "common/error.h"
#include "common/gpu/traverse.h"  // KD_STACK_SIZE

namespace {

constexpr size_t kMaxTriangles = 2048;

// Every leaf's range lies in the leaf index array and names valid triangles; every above
// child lies after its parent, inside the node array (pre-order, below child next).
void check_structure(const mcpt::KdTree& tree, size_t triangles) {
    if (tree.nodes.empty()) std::abort();
    for (uint32_t index : tree.leaf_indices)
        if (index >= triangles) std::abort();
    if (tree.kind == mcpt::TreeKind::Bvh) {
        // Every child inside the node array or the leaf index array, each triangle once.
        std::vector<int> seen(triangles, 0);
        const uint32_t nodes = mcpt::bvh_node_count(tree);
        for (uint32_t i = 0; i < nodes; ++i)
            for (const mcpt::BvhChild& c : mcpt::bvh_children(mcpt::bvh_node(tree, i))) {
                if (c.internal ? (c.index <= i || c.index >= nodes)
                               : (c.index + c.triangles > tree.leaf_indices.size()))
                    std::abort();
            }
        for (uint32_t index : tree.leaf_indices)
            if (++seen[index] > 1) std::abort();
        return;
    }
    for (size_t i = 0; i < tree.nodes.size(); ++i) {
        const mcpt::gpu::KdNode& n = tree.nodes[i];
        if ((n.flags & 3u) == 3u) {
            const uint64_t first = n.split_or_offset, count = n.flags >> 2;
            if (first + count > tree.leaf_indices.size()) std::abort();
            continue;
        }
        const uint32_t above = n.flags >> 2;
        if (above <= i || above >= tree.nodes.size()) std::abort();
    }
}

bool moderate(float v) {
    const float a = std::fabs(v);
    return std::isfinite(v) && (a == 0.f || (a >= 0x1p-10f && a <= 0x1p20f));
}

// Closest hit of every ray through the tree equals brute force over all triangles.
void check_traversal(const mcpt::KdTree& tree, const std::vector<mcpt::Triangle>& tris,
                     const float* ray_floats, size_t ray_count) {
    using namespace mcpt;
    std::vector<gpu::GpuTriangle> g;
    for (const Triangle& t : tris)
        g.push_back({t.v0.x, t.v0.y, t.v0.z, t.v1.x, t.v1.y, t.v1.z, t.v2.x, t.v2.y, t.v2.z, 0u});
    for (size_t r = 0; r < ray_count; ++r) {
        const float* f = ray_floats + 6 * r;
        gpu::Ray ray;
        ray.o = {f[0], f[1], f[2]};
        ray.d = {f[3], f[4], f[5]};
        const float len = std::sqrt(f[3] * f[3] + f[4] * f[4] + f[5] * f[5]);
        if (!(len > 1e-3f) || !std::isfinite(len)) continue;
        ray.d = {f[3] / len, f[4] / len, f[5] / len};
        ray.tmax = 3.0e38f;
        const gpu::Hit b = brute_force_hit(g, ray);
        const float best = b.t;
        const uint32_t best_tri = b.prim;
        const gpu::Hit h = cpu_trace_tree(tree, g, ray);
        const bool exact = tree.kind != TreeKind::Bvh || (h.prim == best_tri && h.t == best);
        const bool agree = h.status == 0u && (h.prim == NO_HIT) == (best_tri == NO_HIT) &&
                           (best_tri == NO_HIT || std::fabs(h.t - best) <= 1e-6f * best) && exact;
        if (!agree) {
            std::fprintf(stderr,
                         "traversal disagrees with brute force: ray (%a %a %a) -> (%a %a %a), "
                         "status %u, tree %u at %a, brute force %u at %a\n",
                         f[0], f[1], f[2], f[3], f[4], f[5], h.status, h.prim, h.t, best_tri, best);
            std::abort();
        }
    }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    using namespace mcpt;
    if (size < 4) return 0;
    TreeOptions options;
    const TreeKind kinds[] = {TreeKind::Sah,  TreeKind::Median, TreeKind::None,
                              TreeKind::Auto, TreeKind::Bvh,    TreeKind::Bvh};
    options.kind = kinds[data[0] % 6u];
    // Depth: -1 (the kind's default) or up to 39; the median tree splits inseparable triangles
    // down to its depth, so deep median trees only meet the builder's size cap, slowly (0.5 s):
    // up to 17 there.
    options.max_depth = data[1] % 64 == 63 ? -1 : data[1] % 64 % 40;
    if (options.kind == TreeKind::Median)
        options.max_depth = options.max_depth < 0 ? 12 : options.max_depth % 18;
    options.max_leaf_prims = 1 + data[2] % 8;
    options.threads = 1 + (data[3] & 1u);
    const uint8_t rays = data[3] >> 1;  // up to 127 rays from the end of the input
    data += 4, size -= 4;
    // The soup: 9 floats per triangle, then the rays (6 floats each).
    const size_t ray_bytes = std::min<size_t>(size / 2, size_t(rays) * 24) / 24 * 24;
    const size_t tri_count = std::min(kMaxTriangles, (size - ray_bytes) / 36);
    std::vector<Triangle> tris(tri_count);
    bool all_moderate = true;
    for (size_t i = 0; i < tri_count; ++i) {
        float v[9];
        std::memcpy(v, data + 36 * i, sizeof v);
        for (float x : v) all_moderate = all_moderate && moderate(x);
        tris[i].v0 = {v[0], v[1], v[2]}, tris[i].v1 = {v[3], v[4], v[5]};
        tris[i].v2 = {v[6], v[7], v[8]};
    }
    KdTree tree;
    try {
        tree = build_kdtree(tris, options);
    } catch (const Error&) {
        return 0;  // refused with a message
    }
    check_structure(tree, tris.size());
    if (all_moderate && tree.stack_size() <= KD_STACK_SIZE && ray_bytes > 0) {
        std::vector<float> ray_floats(ray_bytes / 4);
        std::memcpy(ray_floats.data(), data + size - ray_bytes, ray_bytes);
        bool rays_moderate = true;
        for (float x : ray_floats) rays_moderate = rays_moderate && moderate(x);
        if (rays_moderate) check_traversal(tree, tris, ray_floats.data(), ray_bytes / 24);
    }
    return 0;
}
