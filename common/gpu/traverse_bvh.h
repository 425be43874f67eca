// Closest-hit and any-hit traversal of the 8-wide BVH (shared_types.h: BvhNode), after
// Ylitie, Karras & Laine, "Efficient Incoherent Ray Traversal on GPUs Through Compressed Wide
// BVHs" (HPG 2017): a node's eight child boxes (on a grid, as floats) tested at once, the
// hits kept as bit masks (internal children and leaf triangles) and visited nearest-octant
// first, one 8-byte stack entry per node left with unvisited hits; and the same loop as a walk
// that pauses between iterations (BvhWalk, for integrator.h's step_slot_walk). Included by
// traverse.h, whose closer_triangle_hit() tests the triangles; docs/traversal.md: what was
// measured.
#ifndef MCPT_GPU_TRAVERSE_BVH_H
#define MCPT_GPU_TRAVERSE_BVH_H

MCPT_NAMESPACE_BEGIN

// Relative slack on child-box entry and exit distances: the quantized boxes carry a grid cell
// of margin for the rounding of large terms (the origin inside a node), this covers the
// rounding relative to the distance itself. A child is entered when t0 (1 - s) <= t1 (1 + s)
// for s = 1e-6, tested as t0 <= t1 * BVH_SLACK2, one multiplication: (1 + s) / (1 - s) = 1 +
// 2s + O(s^2), rounded up past the products' own rounding (2^-24 each).
#define BVH_SLACK2 (1.0f + 2.5e-6f)
// Direction components smaller than this take its value (with their sign): finite
// reciprocals, so no 0 * inf in the box tests.
#define BVH_MIN_DIR 1.0e-20f

// Minimum and maximum of box-test distances, never NaN (BVH_MIN_DIR): OpenCL's min and max
// where fmin and fmax would handle NaN (on CPUs, several instructions each instead of one).
#if defined(MCPT_OPENCL) && !defined(MCPT_NVIDIA_OPENCL)
#define BOX_MIN(a, b) min(a, b)
#define BOX_MAX(a, b) max(a, b)
#else
#define BOX_MIN(a, b) MINF(a, b)
#define BOX_MAX(a, b) MAXF(a, b)
#endif

// The node's grid origin (q0.xyz) relative to the ray's origin, in t (ox, oy, oz), and which
// of each axis's planes is nearer (1: hi, for a negative direction). Scalars, not a vec3:
// PoCL ran the bunny 5% slower through float3.
#define BVH_NODE_IN_T(q0, o, inv_d)                                        \
    float ox = (uint_as_float((q0).x) - (o).x) * (inv_d).x;                \
    float oy = (uint_as_float((q0).y) - (o).y) * (inv_d).y;                \
    float oz = (uint_as_float((q0).z) - (o).z) * (inv_d).z;                \
    uint nx = (inv_d).x < 0.0f ? 1u : 0u, ny = (inv_d).y < 0.0f ? 1u : 0u, \
         nz = (inv_d).z < 0.0f ? 1u : 0u

// Child C (a component: x, y, z, w) of a half's four: its entry and exit distances from the
// planes in t, and its hit bits (K: 0-3, its byte of the half's meta words) if the ray enters
// it before t_max.
#define BVH_CHILD_TEST(K, C)                                                                 \
    {                                                                                        \
        float t0 = BOX_MAX(BOX_MAX(near_x.C * inv_d.x + ox, near_y.C * inv_d.y + oy),        \
                           BOX_MAX(near_z.C * inv_d.z + oz, 0.0f));                          \
        float t1 = BOX_MIN(BOX_MIN(far_x.C * inv_d.x + ox, far_y.C * inv_d.y + oy),          \
                           far_z.C * inv_d.z + oz);                                          \
        bool enter = t0 <= BOX_MIN(t1, t_max) * BVH_SLACK2;                                  \
        uint bits = ((child4 >> (8u * K)) & 0xffu) << ((bit4 >> (8u * K)) & 0xffu);          \
        hits |= enter ? bits : 0u;                                                           \
    }

// The node's children the ray enters before t_max: internal children as bits 24 + (slot ^
// oct_inv) (so the highest bit is the nearest octant's child), leaf triangles as bits at
// their offsets from the node's first leaf index. Four slots per meta word: a byte of meta
// is internal when its bits 3 and 4 are set (24 + slot), and its hit bits are its top three
// (0b1 for a node, 0b1, 0b11 or 0b111 for a leaf of 1-3 triangles; 0 for an empty slot).
// `base`: the node's first quad; q0, q1 its first two.
MCPT_FN uint bvh_child_hits(SCENE_PARAMS_ uint base, uvec4 q0, uvec4 q1, vec3 o, vec3 inv_d,
                            uint oct_inv, float t_max) {
    BVH_NODE_IN_T(q0, o, inv_d);
    uint hits = 0u;
    // Two halves of four slots: the halves' loop kept rolled (NVIDIA's OpenCL: +3 to +10%,
    // the most on the textured scene, whose kernel stalled on instruction fetch with both
    // unrolled; the slots' loop rolled as well lost 5% on the 871k dragon).
    // A half without children is skipped (a node of at most four leaves has them in the
    // first). With textures the trip count is the node's (1 when its second half is empty),
    // not a constant: NVIDIA's Vulkan ran the textured scene 18% faster so, the meshes -8% to
    // +2% (docs/traversal.md, "Empty halves").
    uint halves = HAS_FEATURE(FEATURE_TEXTURES) && q1.w == 0u ? 1u : 2u;
    NO_UNROLL
    for (uint h = 0u; h < halves; ++h) {
        uint meta4 = h == 0u ? q1.z : q1.w;
        if (meta4 == 0u) continue;
        uint inner4 = (meta4 & (meta4 << 1u)) & 0x10101010u;
        uint bit4 = (meta4 ^ ((inner4 >> 4u) * oct_inv)) & 0x1f1f1f1fu;
        uint child4 = (meta4 >> 5u) & 0x07070707u;
        // Each axis's near and far planes of the half's four slots (hi is nearer for a
        // negative direction), loaded by quad index rather than selected.
        uint qb = base + BVH_PLANES_QUAD + BVH_HALF_QUADS * h;
        vec4 near_x = AS_VEC4(BVH_QUAD(qb + nx)), far_x = AS_VEC4(BVH_QUAD(qb + 1u - nx));
        vec4 near_y = AS_VEC4(BVH_QUAD(qb + 2u + ny)), far_y = AS_VEC4(BVH_QUAD(qb + 3u - ny));
        vec4 near_z = AS_VEC4(BVH_QUAD(qb + 4u + nz)), far_z = AS_VEC4(BVH_QUAD(qb + 5u - nz));
        BVH_CHILD_TEST(0u, x)
        BVH_CHILD_TEST(1u, y)
        BVH_CHILD_TEST(2u, z)
        BVH_CHILD_TEST(3u, w)
    }
    return hits;
}

#if defined(MCPT_OPENCL) && defined(MCPT_BVH_VECTOR)
// OpenCL on CPU devices: the eight slots at once in OpenCL's 8-wide vectors (one AVX register
// each way), the same arithmetic as bvh_child_hits per lane. Called, not inlined (platform.h:
// MCPT_FN_CALLED).
MCPT_FN_CALLED uint bvh_child_hits_vector(SCENE_PARAMS_ uint base, uvec4 q0, uvec4 q1, vec3 o,
                                          vec3 inv_d, uint oct_inv, float t_max) {
    BVH_NODE_IN_T(q0, o, inv_d);
    // Each axis's near and far planes of the eight slots (hi is nearer for a negative direction).
    uint q = base + BVH_PLANES_QUAD, r = q + BVH_HALF_QUADS;
#define BVH_PLANES8(k) (float8)(as_float4(BVH_QUAD(q + (k))), as_float4(BVH_QUAD(r + (k))))
    float8 near_x = BVH_PLANES8(nx) * inv_d.x + ox, far_x = BVH_PLANES8(1u - nx) * inv_d.x + ox;
    float8 near_y = BVH_PLANES8(2u + ny) * inv_d.y + oy,
           far_y = BVH_PLANES8(3u - ny) * inv_d.y + oy;
    float8 near_z = BVH_PLANES8(4u + nz) * inv_d.z + oz,
           far_z = BVH_PLANES8(5u - nz) * inv_d.z + oz;
#undef BVH_PLANES8
    float8 t0 = max(max(near_x, near_y), max(near_z, (float8)(0.0f)));
    float8 t1 = min(min(far_x, far_y), far_z);
    int8 enter = t0 <= min(t1, (float8)(t_max)) * BVH_SLACK2;
    // Each slot's meta byte: its hit bits and where they go.
    uint8 meta = convert_uint8(as_uchar8(q1.zw));
    uint8 inner = (meta & (meta << 1u)) & 0x10u;
    uint8 bit = (meta ^ ((inner >> 4u) * oct_inv)) & 0x1fu;
    uint8 bits = select((uint8)(0u), ((meta >> 5u) & 0x7u) << bit, enter);
    uint4 h4 = bits.lo | bits.hi;
    uint2 h2 = h4.lo | h4.hi;
    return h2.x | h2.y;
}
#define BVH_CHILD_HITS bvh_child_hits_vector
#else
#define BVH_CHILD_HITS bvh_child_hits
#endif

#if defined(MCPT_OPENCL) && defined(MCPT_BVH_VECTOR)
// OpenCL on CPU devices: closer_triangle_hit for up to four triangles of a node's leaves at
// once (intersect_triangle4), then each lane in order against the hit so far, as the loop of
// single tests takes them: the same hit, bit for bit. With any_hit, the first lane that hits.
MCPT_FN Hit closer_triangle_hits4(SCENE_PARAMS_ Ray ray, WoopRay wr, uint4 tri, uint n, uint skip,
                                  bool any_hit, Hit hit) {
#ifdef MCPT_COUNTERS
    hit.tri_tests += n;
#endif
    TriHit4 h = intersect_triangle4(ray, wr, TRIANGLE(tri.s0), TRIANGLE(tri.s1), TRIANGLE(tri.s2),
                                    TRIANGLE(tri.s3));
    // Lane L against the nearest hit so far (closer_triangle_hit's rules).
#define BVH_ACCEPT_LANE(L)                                                         \
    if (n > L##u) {                                                                \
        bool tie_wins = (hit.prim & SPHERE_BIT) == 0u && tri.s##L < hit.prim;      \
        float tmax = tie_wins ? uint_as_float(float_as_uint(hit.t) + 1u) : hit.t;  \
        bool ok = h.ok.s##L != 0 &&                                                \
                  triangle4_within(h.t_scaled.s##L, h.det.s##L, h.t.s##L, tmax) && \
                  tri.s##L != skip && (h.t.s##L != hit.t || tie_wins);             \
        if (ok) {                                                                  \
            hit.t = h.t.s##L;                                                      \
            hit.b1 = h.b1.s##L;                                                    \
            hit.b2 = h.b2.s##L;                                                    \
            hit.prim = tri.s##L;                                                   \
            if (any_hit) return hit;                                               \
        }                                                                          \
    }
    BVH_ACCEPT_LANE(0)
    BVH_ACCEPT_LANE(1)
    BVH_ACCEPT_LANE(2)
    BVH_ACCEPT_LANE(3)
#undef BVH_ACCEPT_LANE
    return hit;
}
#endif

// Nearest triangle hit closer than hit.t (with any_hit, the first), ignoring `skip`.
MCPT_FN Hit trace_bvh(SCENE_PARAMS_ Ray ray, WoopRay wr, bool any_hit, uint skip, Hit hit) {
    vec3 d = ray.d;
    d.x = ABSF(d.x) < BVH_MIN_DIR ? (d.x < 0.0f ? -BVH_MIN_DIR : BVH_MIN_DIR) : d.x;
    d.y = ABSF(d.y) < BVH_MIN_DIR ? (d.y < 0.0f ? -BVH_MIN_DIR : BVH_MIN_DIR) : d.y;
    d.z = ABSF(d.z) < BVH_MIN_DIR ? (d.z < 0.0f ? -BVH_MIN_DIR : BVH_MIN_DIR) : d.z;
    vec3 inv_d = V3(1.0f / d.x, 1.0f / d.y, 1.0f / d.z);
    // Slot s is nearest for directions whose negative axes are its bits; XOR with the
    // complement of the ray's octant makes that slot's bit the highest.
    uint oct_inv = (d.x < 0.0f ? 0u : 4u) | (d.y < 0.0f ? 0u : 2u) | (d.z < 0.0f ? 0u : 1u);

    // A group: (first node index, hit bits << 24 | imask) or (first leaf index, triangle
    // bits). The root is the only child of a pseudo-node at index 0.
    uvec2 node_group = UV2(0u, 0x80000000u);
    uvec2 tri_group = UV2(0u, 0u);
    uvec2 stack[KD_STACK_SIZE];
    uint sp = 0u;
    bool finished = false;  // set at the one real exit (see TRACE_INCOMPLETE)
    // A node per iteration, then the triangles of its hit leaves, then the next node: its
    // parent's next hit child, else the last group left on the stack. (One step per
    // iteration, a triangle or a node as the k-d traversal takes them, ran 3-7% slower on
    // NVIDIA: docs/traversal.md.)
    while (true) {
        if ((node_group.y & 0xff000000u) != 0u) {
            // The nearest hit child of the group; the rest stays on the stack.
            uint bit = FIND_MSB(node_group.y);
            uint slot = (bit - 24u) ^ oct_inv;
            uint below = node_group.y & 0xffu & ~(0xffffffffu << slot);
            uint child = node_group.x + BIT_COUNT(below);
            node_group.y &= ~(1u << bit);
            if ((node_group.y & 0xff000000u) != 0u) {
                if (sp >= KD_STACK_SIZE) {
                    hit.status = TRACE_STACK_OVERFLOW;
                    return hit;
                }
                stack[sp] = node_group;
                sp += 1u;
            }
#ifdef MCPT_COUNTERS
            hit.node_visits += 1u;
#endif
            // Its children: a node group and a triangle group.
            uint base = BVH_NODE_UNITS / 2u * child;
            uvec4 q0 = BVH_QUAD(base), q1 = BVH_QUAD(base + 1u);
            uint hits = BVH_CHILD_HITS(SCENE_ARGS_ base, q0, q1, ray.o, inv_d, oct_inv, hit.t);
            node_group = UV2(q1.x, (hits & 0xff000000u) | (q0.w >> 24u));
            tri_group = UV2(q1.y, hits & 0x00ffffffu);
        }
        // The triangles of the node's hit leaves (CPU devices: four at a time).
#if defined(MCPT_OPENCL) && defined(MCPT_BVH_VECTOR)
        while (tri_group.y != 0u) {
            // Lane n takes the n-th triangle popped; the lanes after it repeat it (tested,
            // never accepted: n counts the real ones).
            uint4 tri = (uint4)(0u);
            uint n = 0u;
            for (; n < 4u && tri_group.y != 0u; ++n) {
                uint bit = FIND_MSB(tri_group.y);
                tri_group.y &= ~(1u << bit);
                uint t = LEAF_INDEX(tri_group.x + bit);
                tri = (uint4)(n == 0u ? t : tri.s0, n <= 1u ? t : tri.s1, n <= 2u ? t : tri.s2, t);
            }
            float nearest = hit.t;
            hit = closer_triangle_hits4(SCENE_ARGS_ ray, wr, tri, n, skip, any_hit, hit);
            if (any_hit && hit.t < nearest) return hit;
        }
#endif
        while (tri_group.y != 0u) {
            uint bit = FIND_MSB(tri_group.y);
            tri_group.y &= ~(1u << bit);
            float nearest = hit.t;
            hit =
                closer_triangle_hit(SCENE_ARGS_ ray, wr, LEAF_INDEX(tri_group.x + bit), skip, hit);
            if (any_hit && hit.t < nearest) return hit;
        }
        // Next: the group's other hit children, else the last group left on the stack.
        if ((node_group.y & 0xff000000u) == 0u) {
            if (sp == 0u) {
                finished = true;
                break;
            }
            sp -= 1u;
            node_group = stack[sp];
        }
    }
    if (!finished) hit.status = TRACE_INCOMPLETE;
    return hit;
}

// A ray's walk through the BVH that stops and resumes between iterations (integrator.h:
// step_slot_walk): trace_bvh's loop state, its stack held by the caller. `done`: the hit is
// final (or its status says why not).
MCPT_STRUCT(BvhWalk) {
    vec3 inv_d;
    uint oct_inv;
    uvec2 node_group, tri_group;
    uint sp;
    bool done;
};

// The walk of a ray with direction d from the root (trace_bvh's set-up).
MCPT_FN BvhWalk bvh_walk_begin(vec3 d) {
    d.x = ABSF(d.x) < BVH_MIN_DIR ? (d.x < 0.0f ? -BVH_MIN_DIR : BVH_MIN_DIR) : d.x;
    d.y = ABSF(d.y) < BVH_MIN_DIR ? (d.y < 0.0f ? -BVH_MIN_DIR : BVH_MIN_DIR) : d.y;
    d.z = ABSF(d.z) < BVH_MIN_DIR ? (d.z < 0.0f ? -BVH_MIN_DIR : BVH_MIN_DIR) : d.z;
    BvhWalk w;
    w.inv_d = V3(1.0f / d.x, 1.0f / d.y, 1.0f / d.z);
    w.oct_inv = (d.x < 0.0f ? 0u : 4u) | (d.y < 0.0f ? 0u : 2u) | (d.z < 0.0f ? 0u : 1u);
    w.node_group = UV2(0u, 0x80000000u);
    w.tri_group = UV2(0u, 0u);
    w.sp = 0u;
    w.done = false;
    return w;
}

// One iteration of trace_bvh's loop on walk W (its stack STACK): a node, the triangles of its
// hit leaves, then the next group; W.done where trace_bvh would return. A macro: the stack is
// an array of the caller's (no pointers in the shared dialect, GLSL copies array arguments).
#define BVH_WALK_ITERATION(W, STACK, RAY, WR, ANY_HIT, SKIP, HIT)                               \
    {                                                                                           \
        if (((W).node_group.y & 0xff000000u) != 0u) {                                           \
            uint bit = FIND_MSB((W).node_group.y);                                              \
            uint slot = (bit - 24u) ^ (W).oct_inv;                                              \
            uint below = (W).node_group.y & 0xffu & ~(0xffffffffu << slot);                     \
            uint child = (W).node_group.x + BIT_COUNT(below);                                   \
            (W).node_group.y &= ~(1u << bit);                                                   \
            if (((W).node_group.y & 0xff000000u) != 0u) {                                       \
                if ((W).sp >= KD_STACK_SIZE) {                                                  \
                    (HIT).status = TRACE_STACK_OVERFLOW;                                        \
                    (W).done = true;                                                            \
                } else {                                                                        \
                    STACK[(W).sp] = (W).node_group;                                             \
                    (W).sp += 1u;                                                               \
                }                                                                               \
            }                                                                                   \
            if (!(W).done) {                                                                    \
                uint base = BVH_NODE_UNITS / 2u * child;                                        \
                uvec4 q0 = BVH_QUAD(base), q1 = BVH_QUAD(base + 1u);                            \
                uint hits = BVH_CHILD_HITS(SCENE_ARGS_ base, q0, q1, (RAY).o, (W).inv_d,        \
                                           (W).oct_inv, (HIT).t);                               \
                (W).node_group = UV2(q1.x, (hits & 0xff000000u) | (q0.w >> 24u));               \
                (W).tri_group = UV2(q1.y, hits & 0x00ffffffu);                                  \
            }                                                                                   \
        }                                                                                       \
        while (!(W).done && (W).tri_group.y != 0u) {                                            \
            uint bit = FIND_MSB((W).tri_group.y);                                               \
            (W).tri_group.y &= ~(1u << bit);                                                    \
            float nearest = (HIT).t;                                                            \
            (HIT) = closer_triangle_hit(SCENE_ARGS_ RAY, WR, LEAF_INDEX((W).tri_group.x + bit), \
                                        SKIP, HIT);                                             \
            if ((ANY_HIT) && (HIT).t < nearest) (W).done = true;                                \
        }                                                                                       \
        if (!(W).done && ((W).node_group.y & 0xff000000u) == 0u) {                              \
            if ((W).sp == 0u) {                                                                 \
                (W).done = true;                                                                \
            } else {                                                                            \
                (W).sp -= 1u;                                                                   \
                (W).node_group = STACK[(W).sp];                                                 \
            }                                                                                   \
        }                                                                                       \
    }

MCPT_NAMESPACE_END

#endif  // MCPT_GPU_TRAVERSE_BVH_H
