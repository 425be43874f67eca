// Closest-hit and any-hit queries: spheres by brute force, triangles through the k-d tree
// (pbrt-v3 KdTreeAccel traversal, front-to-back with a stack of KD_STACK_SIZE entries, which
// the host sizes from the built tree's depth; a node step and a triangle test of the current
// leaf per loop iteration; a mailbox against repeated triangle tests). docs/traversal.md:
// what was measured.
#ifndef MCPT_GPU_TRAVERSE_H
#define MCPT_GPU_TRAVERSE_H

#include "intersect.h"
#include "scene_access.h"
#include "texture.h"

MCPT_NAMESPACE_BEGIN

// Relative slack on node-interval pruning: visiting a child too many is harmless, skipping
// one the ray reaches after rounding is not.
#define KD_SLACK 1.0e-6f

// Several node steps and triangles per loop iteration (KD_NODE_STEPS, KD_TRI_STEPS), as loops:
// in the Vulkan module for GPUs always (specialization constants; at one step each it ran
// NVIDIA's Vulkan 3-5% faster than the plain loop body), in OpenCL builds when asked for more
// than one. The plain body elsewhere: NVIDIA's OpenCL compiler ran the loops' form 16-18%
// slower and lavapipe 35% slower at one step, and no step count beat the plain body there
// (docs/traversal.md).
// Tests run the GPUs' loop on CPU devices, in place of the loop over each leaf.
#if defined(MCPT_KD_STEP_BY_STEP)
#undef MCPT_KD_LEAF_LOOP
#endif
#if defined(MCPT_GLSL)
#if !defined(MCPT_SCENE_TEXELS)
#define KD_STEP_LOOPS 1
#endif
#elif KD_NODE_STEPS > 1u || KD_TRI_STEPS > 1u
#define KD_STEP_LOOPS 1
#endif
// Overlapped steps (KD_OVERLAP, on by default): an iteration that tests a triangle of the
// current leaf also takes a node step, so a lane's iterations are about its node steps, not
// its node steps plus its triangle tests (NVIDIA's OpenCL +7 to +10% on the meshes, lavapipe
// +18 to +27%; docs/traversal.md). The next leaf waits for the current one's triangles, so
// leaves are tested in the same order and every hit is the same; a node step may visit a node
// the pending triangles would have culled, which is correct, only wasted. The C++ build
// overlaps where the scene flag SCENE_KD_OVERLAP asks (tests: its counts describe the tree).
#if defined(MCPT_CPP)
#define KD_OVERLAP_STEPS ((PARAM(scene_flags) & SCENE_KD_OVERLAP) != 0u)
#else
#define KD_OVERLAP_STEPS (KD_OVERLAP != 0u)
#endif
#if defined(KD_STEP_LOOPS)
// `continue` takes the next step; KD_NODE_STEPS_EXIT ends the steps (as it does after a
// leaf: its triangles first), `break` (with finished set) the traversal.
#define KD_NODE_STEPS_BEGIN \
    bool leaf = false;      \
    for (uint step = 0u; step < KD_NODE_STEPS; ++step) {
#define KD_NODE_STEPS_LEAF leaf = true
#define KD_NODE_STEPS_POPPED \
    if (leaf) break
#define KD_NODE_STEPS_EXIT break
#define KD_TRI_STEPS_BEGIN for (uint k = 0u; k < KD_TRI_STEPS && tri_left > 0u; ++k) {
#else
#define KD_NODE_STEPS_BEGIN {
#define KD_NODE_STEPS_LEAF
#define KD_NODE_STEPS_POPPED
#define KD_NODE_STEPS_EXIT continue
#define KD_TRI_STEPS_BEGIN {
#endif

// Triangle tri_index against the ray, up to the nearest hit so far: the updated hit. Of two
// triangles at the same distance the lower index wins, so the hit does not depend on the
// order a traversal tests them in (the k-d tree, the BVH and brute force agree exactly).
MCPT_FN Hit closer_triangle_hit(SCENE_PARAMS_ Ray ray, WoopRay wr, uint tri_index, uint skip,
                                Hit hit) {
#ifdef MCPT_COUNTERS
    hit.tri_tests += 1u;
#endif
    Ray r = ray;
    bool tie_wins = (hit.prim & SPHERE_BIT) == 0u && tri_index < hit.prim;
    r.tmax = tie_wins ? uint_as_float(float_as_uint(hit.t) + 1u) : hit.t;  // t > 0: one ulp up
    TriHit th = intersect_triangle(r, wr, TRIANGLE(tri_index));
    if (th.hit && tri_index == skip) th.hit = false;  // the cut-out the ray passed through
    if (th.hit && th.t == hit.t && !tie_wins) th.hit = false;
    if (th.hit) {
        hit.t = th.t;
        hit.b1 = th.b1;
        hit.b2 = th.b2;
        hit.prim = tri_index;
    }
    return hit;
}

// Mailbox of the last four triangles a ray tested (MCPT_KD_MAILBOX: OpenCL builds and the
// Vulkan module for GPUs). A k-d tree references a triangle from every leaf it overlaps, and
// a third of the tests would repeat one just done (CPU count on the dragon); a repeat cannot
// find a nearer hit, so it is skipped (NVIDIA: +3 to +7% on the meshes; docs/traversal.md).
// lavapipe runs both sides of a branch under a mask, so skipping saves it nothing and the
// check cost it 10-25%; its module and the C++ build (whose counts report the tree's own
// tests) go without.
MCPT_STRUCT(LeafHit) {
    Hit hit;
    uvec4 mailbox;
};

// Triangle tri of a leaf against the ray: skipped when the mailbox holds it, else tested and
// remembered.
MCPT_FN LeafHit leaf_triangle_hit(SCENE_PARAMS_ Ray ray, WoopRay wr, uint tri, uint skip, Hit hit,
                                  uvec4 mailbox) {
    LeafHit r;
    r.hit = hit;
    r.mailbox = mailbox;
#if defined(MCPT_KD_MAILBOX)
    if (tri == mailbox.x || tri == mailbox.y || tri == mailbox.z || tri == mailbox.w) return r;
    r.mailbox = UV4(tri, mailbox.x, mailbox.y, mailbox.z);
#endif
    r.hit = closer_triangle_hit(SCENE_ARGS_ ray, wr, tri, skip, hit);
    return r;
}

MCPT_NAMESPACE_END
#include "traverse_bvh.h"
MCPT_NAMESPACE_BEGIN

// No hit before tmax, nothing counted: where every query starts.
MCPT_FN Hit no_hit(float tmax) {
    Hit h;
    h.t = tmax;
    h.b1 = 0.0f;
    h.b2 = 0.0f;
    h.prim = NO_HIT;
    h.status = 0u;
    h.tri_tests = 0u;
    h.node_visits = 0u;
    return h;
}

#if defined(MCPT_RAY_QUERY) || defined(MCPT_RAY_PIPELINE)
MCPT_NAMESPACE_END
#include "traverse_driver.h"
MCPT_NAMESPACE_BEGIN
#else
// Spheres: few, tested one by one. The nearest hit with t < ray.tmax; with any_hit, the
// first. (trace_opaque, and step_slot_walk before its walk.)
MCPT_FN Hit sphere_hit(SCENE_PARAMS_ Ray ray, bool any_hit) {
    Hit hit = no_hit(ray.tmax);
    uint num_spheres = HAS_FEATURE(FEATURE_SPHERES) ? PARAM(num_spheres) : 0u;
    uint s = 0u;
    for (; s < num_spheres; ++s) {
        Ray r = ray;
        r.tmax = hit.t;
        float t = intersect_sphere(r, SPHERE(s));
        if (t > 0.0f) {
            hit.t = t;
            hit.prim = s | SPHERE_BIT;
            if (any_hit) return hit;
        }
    }
    if (s < num_spheres) hit.status = TRACE_INCOMPLETE;
    return hit;
}

// Nearest hit with t < ray.tmax, ignoring triangle `skip`; with any_hit, the first hit found.
MCPT_FN Hit trace_opaque(SCENE_PARAMS_ Ray ray, bool any_hit, uint skip) {
    Hit hit = sphere_hit(SCENE_ARGS_ ray, any_hit);
    if (any_hit && hit.prim != NO_HIT) return hit;
    if (!HAS_FEATURE(FEATURE_TRIANGLES) || PARAM(num_triangles) == 0u) return hit;
    WoopRay wr = woop_setup(ray.d);

    // The BVH, where the scene has one (traverse_bvh.h).
    if (HAS_FEATURE(FEATURE_BVH) && (PARAM(scene_flags) & SCENE_BVH) != 0u)
        return trace_bvh(SCENE_ARGS_ ray, wr, any_hit, skip, hit);

    // Without a tree: every triangle, no stack.
    if (!HAS_FEATURE(FEATURE_KDTREE)) {
        uint i = 0u;
        for (; i < PARAM(num_triangles); ++i) {
            float nearest = hit.t;
            hit = closer_triangle_hit(SCENE_ARGS_ ray, wr, i, skip, hit);
            if (any_hit && hit.t < nearest) return hit;
        }
        if (i < PARAM(num_triangles)) hit.status = TRACE_INCOMPLETE;
        return hit;
    }

    // Clip the ray to the scene bounds.
    vec3 inv_d = V3(1.0f / ray.d.x, 1.0f / ray.d.y, 1.0f / ray.d.z);
    vec2 range =
        intersect_bounds(ray, V3(PARAM(scene_min_x), PARAM(scene_min_y), PARAM(scene_min_z)),
                         V3(PARAM(scene_max_x), PARAM(scene_max_y), PARAM(scene_max_z)), inv_d);
    if (range.x > range.y) return hit;
    float tmin = range.x, tmax = range.y;

    uint stack_node[KD_STACK_SIZE];
    float stack_tmin[KD_STACK_SIZE];
    float stack_tmax[KD_STACK_SIZE];
    uint sp = 0u;
    uint node = 0u;
    bool finished = false;  // set at the one real exit (see TRACE_INCOMPLETE)
    // One step per iteration, a node or one triangle of the current leaf (or both, with
    // KD_OVERLAP): a lane at a leaf does not hold its warp or SIMD group for the whole leaf
    // (NVIDIA: up to +10% on the meshes, lavapipe +5 to +15%). Scalar CPU code is faster
    // with an inner loop over the leaf (PoCL: 7-10%), which OpenCL builds for CPU devices
    // take (MCPT_KD_LEAF_LOOP).
    uint tri_next = 0u, tri_left = 0u;
    uvec4 mailbox = UV4(NO_HIT, NO_HIT, NO_HIT, NO_HIT);
#if !defined(MCPT_KD_LEAF_LOOP)
    bool done = false;
#endif
    while (true) {
#if !defined(MCPT_KD_LEAF_LOOP)
        if (tri_left > 0u) {
            // Up to KD_TRI_STEPS triangles of the leaf.
            KD_TRI_STEPS_BEGIN
            float nearest = hit.t;
            uint tri = LEAF_INDEX(tri_next);
            LeafHit lh = leaf_triangle_hit(SCENE_ARGS_ ray, wr, tri, skip, hit, mailbox);
            hit = lh.hit;
            mailbox = lh.mailbox;
            if (any_hit && hit.t < nearest) return hit;
            tri_next += 1u;
            tri_left -= 1u;
        }
            if (!KD_OVERLAP_STEPS) continue;  // else also a node step
        }
        if (done) {
            if (tri_left == 0u) {
                finished = true;
                break;
            }
            continue;
        }
#endif
        // Up to KD_NODE_STEPS node steps (scene_access.h), each visiting a node or passing
        // one that starts beyond the nearest hit, until a leaf: lanes at interior nodes keep
        // pace with lanes testing a triangle.
        KD_NODE_STEPS_BEGIN
        // Visit the node unless it starts beyond the nearest hit.
        if (hit.t >= tmin) {
#ifdef MCPT_COUNTERS
            hit.node_visits += 1u;
#endif
            KdNode n = NODE(node);
            uint axis = n.flags & 3u;
            if (axis != KD_LEAF) {
                // Interior: order the children along the ray.
                float split = uint_as_float(n.split_or_offset);
                float o_a = vec3_at(ray.o, axis);
                float d_a = vec3_at(ray.d, axis);
                float t_plane = (split - o_a) * vec3_at(inv_d, axis);
                bool below_first = (o_a < split) || (o_a == split && d_a <= 0.0f);
                uint above = n.flags >> 2u;
                uint first = below_first ? node + 1u : above;
                uint second = below_first ? above : node + 1u;
                bool in_plane = t_plane != t_plane;  // NaN: ray lies in the split plane
                if (!in_plane && (t_plane > tmax * (1.0f + KD_SLACK) || t_plane <= 0.0f)) {
                    node = first;
                } else if (!in_plane && t_plane < tmin * (1.0f - KD_SLACK)) {
                    node = second;
                } else {
                    // Both: defer the far child.
                    if (sp >= KD_STACK_SIZE) {
                        hit.status = TRACE_STACK_OVERFLOW;
                        return hit;
                    }
                    float t_split = in_plane ? tmin : t_plane;
                    stack_node[sp] = second;
                    stack_tmin[sp] = t_split * (1.0f - KD_SLACK);
                    stack_tmax[sp] = tmax;
                    sp += 1u;
                    node = first;
                    tmax = in_plane ? tmax : t_plane * (1.0f + KD_SLACK);
                }
                continue;
            }
            // Leaf: its triangles, in the next iterations (before the next node's visit)
            // or in a loop here.
#if !defined(MCPT_KD_LEAF_LOOP)
            // Overlapped: a leaf waits for the last one's triangles.
            if (KD_OVERLAP_STEPS && tri_left > 0u) KD_NODE_STEPS_EXIT;
#endif
            KD_NODE_STEPS_LEAF;
            tri_left = n.flags >> 2u;
            tri_next = n.split_or_offset;
#if defined(MCPT_KD_LEAF_LOOP)
            for (; tri_left > 0u; --tri_left) {
                float nearest = hit.t;
                uint tri = LEAF_INDEX(tri_next);
                LeafHit lh = leaf_triangle_hit(SCENE_ARGS_ ray, wr, tri, skip, hit, mailbox);
                hit = lh.hit;
                mailbox = lh.mailbox;
                if (any_hit && hit.t < nearest) return hit;
                tri_next += 1u;
            }
#endif
        }
        // Next deferred node. Pop on past nodes that start beyond the hit rather than stop
        // at the first: a ray lying in a split plane defers the far child with the near
        // child's tmin, so the stack is not sorted by distance there.
        if (sp == 0u) {
#if defined(MCPT_KD_LEAF_LOOP)
            finished = true;
            break;
#else
            done = true;  // after the leaf's triangles
            KD_NODE_STEPS_EXIT;
#endif
        }
        sp -= 1u;
        node = stack_node[sp];
        tmin = stack_tmin[sp];
        tmax = stack_tmax[sp];
        KD_NODE_STEPS_POPPED;
        }
#if defined(MCPT_KD_LEAF_LOOP)
        if (finished) break;
#endif
    }
    if (!finished) hit.status = TRACE_INCOMPLETE;
    return hit;
}

// Cut-outs a ray passes through at most; a ray that meets more is cut short (TRACE_INCOMPLETE:
// its sample is counted as invalid, never added).
#define MAX_CUTOUTS 64u

// Nearest hit with t < ray.tmax; with any_hit, the first hit found. In scenes with alphaMode
// MASK materials, the nearest hit is found, and passed through while its material is cut out
// there (outside the traversal loop, which stays as lean as without masks). One call of the
// traversal, so each query inlines one copy of it (with one copy for the masks' loop and one
// for the rest, the textured scene's BVH kernel ran 10% slower on NVIDIA's Vulkan).
MCPT_FN Hit trace_ray(SCENE_PARAMS_ Ray ray, bool any_hit) {
    bool masks = HAS_FEATURE(FEATURE_ALPHA_MASK) && (PARAM(scene_flags) & SCENE_ALPHA_MASK) != 0u;
    Ray r = ray;
    float t_base = 0.0f;
    uint skip = NO_HIT, tri_tests = 0u, node_visits = 0u;
    for (uint k = 0u; k < MAX_CUTOUTS; ++k) {
        Hit hit = trace_opaque(SCENE_ARGS_ r, any_hit && !masks, skip);
        tri_tests += hit.tri_tests;
        node_visits += hit.node_visits;
        if (!masks || hit.prim == NO_HIT || hit.status != 0u || (hit.prim & SPHERE_BIT) != 0u ||
            opaque_at(SCENE_ARGS_ TRIANGLE(hit.prim).material, hit.prim, hit.b1, hit.b2)) {
            hit.t += t_base;  // + 0 without masks: the same bits
            hit.tri_tests = tri_tests;
            hit.node_visits = node_visits;
            return hit;
        }
        // Cut out here: continue from the hit point, past this triangle.
        r.o = r.o + r.d * hit.t;
        r.tmax -= hit.t;
        t_base += hit.t;
        skip = hit.prim;
    }
    Hit cut = no_hit(ray.tmax);
    cut.status = TRACE_INCOMPLETE;
    cut.tri_tests = tri_tests;
    cut.node_visits = node_visits;
    return cut;
}

#endif  // MCPT_RAY_QUERY || MCPT_RAY_PIPELINE

MCPT_NAMESPACE_END

#endif  // MCPT_GPU_TRAVERSE_H
