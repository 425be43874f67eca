// Picking a local light (emissive triangle or sphere, point or spot lamp) by where the shading
// point is: a descent of the light tree (common/render/light_tree.h), each child taken with
// probability proportional to its importance, power / max(d^2, r^2), d the distance from x to
// the centre of its bounds and r their half diagonal (never 0: at least light_tree_eps2),
// times how far its lights' cone of emission turns towards x and how far the bounds rise above
// the receiver's tangent plane. The
// pick's probability is the product of the branches taken; for MIS on a BSDF-sampled hit the
// same walk follows the light's trail. Nodes and trails live after the texels.
#ifndef MCPT_GPU_LIGHT_TREE_H
#define MCPT_GPU_LIGHT_TREE_H

#include "lang.h"
#include "ray_types.h"
#include "scene_access.h"

MCPT_NAMESPACE_BEGIN

// The receiver normal a path carries to its next vertex, for the tree's pmf in MIS: two
// floats (octahedral), or NO_RECEIVER (no bound). Both vertices use the decoded normal, so the
// pick and the pmf see the same one.
#define NO_RECEIVER V2(4.0f, 0.0f)
MCPT_FN vec2 receiver_encode(vec3 n) {
    float l1 = ABSF(n.x) + ABSF(n.y) + ABSF(n.z);
    vec2 p = V2(DIVF(n.x, l1), DIVF(n.y, l1));
    if (n.z < 0.0f) {
        float px = p.x, py = p.y;
        p.x = (1.0f - ABSF(py)) * (px >= 0.0f ? 1.0f : -1.0f);
        p.y = (1.0f - ABSF(px)) * (py >= 0.0f ? 1.0f : -1.0f);
    }
    return p;
}
MCPT_FN vec3 receiver_decode(vec2 e) {
    if (e.x > 2.0f) return V3S(0.0f);
    vec3 n = V3(e.x, e.y, 1.0f - ABSF(e.x) - ABSF(e.y));
    float t = MAXF(-n.z, 0.0f);
    n.x += n.x >= 0.0f ? -t : t;
    n.y += n.y >= 0.0f ? -t : t;
    return normalize(n);
}

// cos(max(0, a - b)) and sin of it, from the sines and cosines of angles a, b in [0, pi].
MCPT_FN float cos_sub_clamped(float sin_a, float cos_a, float sin_b, float cos_b) {
    return cos_a > cos_b ? 1.0f : cos_a * cos_b + sin_a * sin_b;
}
MCPT_FN float sin_sub_clamped(float sin_a, float cos_a, float sin_b, float cos_b) {
    return cos_a > cos_b ? 0.0f : sin_a * cos_b - cos_a * sin_b;
}

// Importance of node i's lights at x: power / max(d^2, r^2), times the cosine of the least
// angle between a direction the node's lights emit into and the way to x (pbrt-v4's
// LightBounds::Importance), times the cosine of the least angle between the receiver's normal
// rn and a way into the bounds (one-sided: rn faces where light can come from; rn = 0 at
// receivers lit from every side). Where no light of the node can reach x, 1/1000 of that for
// each bound (no light is ever left out: MIS would miss it).
MCPT_FN float light_node_importance(SCENE_PARAMS_ uint i, vec3 x, vec3 rn) {
    uint at = PARAM(light_tree_word) + 12u * i;
    vec4 a = SCENE_VEC4(at);
    vec4 b = SCENE_VEC4(at + 4u);
    vec4 c = SCENE_VEC4(at + 8u);
    vec3 lo = V3(a.x, a.y, a.z), hi = V3(b.x, b.y, b.z);
    vec3 e = hi - lo, d = x - (lo + hi) * 0.5f;
    float r2 = 0.25f * dot(e, e), d2 = dot(d, d);
    float base = DIVF(a.w, MAXF(MAXF(d2, r2), PARAM(light_tree_eps2)));
    // x within the bounds' sphere: nothing to take off.
    if (d2 <= r2) return base;
    // theta_b: the bounds seen from x.
    float inv_d = inversesqrt(d2);
    float sin_b = sqrt(r2 / d2), cos_b = sqrt(MAXF(0.0f, 1.0f - r2 / d2));
    float bound = 1.0f;
    if (c.w > -1.0f) {
        // theta_w: the axis to the way to x; theta_o: the cone. Each light emits over a
        // hemisphere about its direction.
        float cos_w = dot(V3(c.x, c.y, c.z), d) * inv_d;
        float sin_w = sqrt(MAXF(0.0f, 1.0f - cos_w * cos_w));
        float sin_o = sqrt(MAXF(0.0f, 1.0f - c.w * c.w));
        float cos_x = cos_sub_clamped(sin_w, cos_w, sin_o, c.w);
        float sin_x = sin_sub_clamped(sin_w, cos_w, sin_o, c.w);
        bound = MAXF(cos_sub_clamped(sin_x, cos_x, sin_b, cos_b), 1e-3f);
    }
    if (dot(rn, rn) > 0.0f) {
        // theta_i: the receiver's normal to the way to the bounds' centre.
        float cos_i = -dot(rn, d) * inv_d;
        float sin_i = sqrt(MAXF(0.0f, 1.0f - cos_i * cos_i));
        bound *= MAXF(cos_sub_clamped(sin_i, cos_i, sin_b, cos_b), 1e-3f);
    }
    return base * bound;
}

MCPT_FN uint light_node_child(SCENE_PARAMS_ uint i) {
    return SCENE_WORD(PARAM(light_tree_word) + 12u * i + 7u);
}

// The probability of taking the first of children c and c + 1 at x (receiver normal rn).
MCPT_FN float light_first_child_probability(SCENE_PARAMS_ uint c, vec3 x, vec3 rn) {
    float i0 = light_node_importance(SCENE_ARGS_ c, x, rn);
    float i1 = light_node_importance(SCENE_ARGS_ c + 1u, x, rn);
    float sum = i0 + i1;
    // Both beyond float range or both nothing: alike (never a branch of probability 0 that
    // holds a light, which MIS would then miss).
    return sum > 0.0f && sum <= MCPT_FLT_MAX ? i0 / sum : 0.5f;
}

MCPT_STRUCT(TreePick) {
    uint slot;  // in the light table
    float pmf;  // of the pick, within the tree
};

// A local light for x (receiver normal rn, or 0), by the uniform u.
MCPT_FN TreePick light_tree_pick(SCENE_PARAMS_ vec3 x, vec3 rn, float u) {
    TreePick p;
    p.pmf = 1.0f;
    uint node = 0u;
    for (uint depth = 0u; depth < 33u; ++depth) {
        uint child = light_node_child(SCENE_ARGS_ node);
        if ((child & LIGHT_TREE_LEAF) != 0u) {
            p.slot = child & ~LIGHT_TREE_LEAF;
            return p;
        }
        float first = light_first_child_probability(SCENE_ARGS_ child, x, rn);
        if (u < first) {
            u = u / first;
            p.pmf *= first;
            node = child;
        } else {
            u = (u - first) / (1.0f - first);
            p.pmf *= 1.0f - first;
            node = child + 1u;
        }
        u = MINF(u, 0.99999994f);
    }
    p.slot = 0u;
    p.pmf = 0.0f;  // not reached: the builder stops at 32 levels
    return p;
}

// The probability that light_tree_pick at x (receiver normal rn) takes the light whose trail
// is `trail`.
MCPT_FN float light_tree_pmf(SCENE_PARAMS_ vec3 x, vec3 rn, uint trail) {
    float pmf = 1.0f;
    uint node = 0u;
    for (uint depth = 0u; depth < 33u; ++depth) {
        uint child = light_node_child(SCENE_ARGS_ node);
        if ((child & LIGHT_TREE_LEAF) != 0u) return pmf;
        float first = light_first_child_probability(SCENE_ARGS_ child, x, rn);
        bool second = ((trail >> depth) & 1u) != 0u;
        pmf *= second ? 1.0f - first : first;
        node = second ? child + 1u : child;
    }
    return 0.0f;
}

// The trail of the light whose prim (LIGHT_* bits, shared_types.h) is `prim`: a binary search
// of the (prim, trail) pairs; NO_HIT if it is none of the tree's.
MCPT_FN uint light_tree_trail(SCENE_PARAMS_ uint prim) {
    uint lo = 0u, hi = PARAM(num_light_trails);
    while (lo < hi) {
        uint mid = (lo + hi) / 2u;
        uint p = SCENE_WORD(PARAM(light_trails_word) + 2u * mid);
        if (p == prim) return SCENE_WORD(PARAM(light_trails_word) + 2u * mid + 1u);
        if (p < prim) lo = mid + 1u; else hi = mid;
    }
    return NO_HIT;
}

MCPT_NAMESPACE_END

#endif  // MCPT_GPU_LIGHT_TREE_H
