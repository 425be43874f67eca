// Closest-hit and any-hit queries handed to the driver (GLSL with GL_EXT_ray_query, the module
// built with MCPT_RAY_QUERY; --tree rayquery): the third trace mode beside the k-d tree
// (traverse.h) and the wide BVH (traverse_bvh.h), with the same trace_ray() contract. The
// host builds one top-level structure over two bottom-level ones (vk_accel.cpp): the triangles
// in index order (primitive i is triangle i; opaque, or non-opaque where some material has an
// alpha mask, whose cut-outs are tested here), and one box per sphere (procedural, the sphere
// test here). Ties between triangles at one distance resolve as the driver orders them, not
// by index as the software traversals do.
#ifndef MCPT_GPU_TRAVERSE_RAYQUERY_H
#define MCPT_GPU_TRAVERSE_RAYQUERY_H

MCPT_NAMESPACE_BEGIN

#ifndef RQ_TMIN_REL
#define RQ_TMIN_REL (64.0f * MCPT_FLOAT_EPS)
#endif

layout(binding = BINDING_TLAS) uniform accelerationStructureEXT scene_tlas;

// Nearest hit with t < ray.tmax; with any_hit, the first hit found (the query ends at the
// first one committed). Cut-outs (alpha masks) and spheres are decided in the query's loop.
MCPT_FN Hit trace_ray(SCENE_PARAMS_ Ray ray, bool any_hit) {
    bool masks = HAS_FEATURE(FEATURE_ALPHA_MASK) && (PARAM(scene_flags) & SCENE_ALPHA_MASK) != 0u;
    Hit hit = no_hit(ray.tmax);
    uint flags = any_hit ? gl_RayFlagsTerminateOnFirstHitEXT : gl_RayFlagsNoneEXT;
    rayQueryEXT q;
    vec3 ao = abs(ray.o);
    float tmin = RQ_TMIN_REL * max(max(ao.x, ao.y), ao.z) / length(ray.d);
    rayQueryInitializeEXT(q, scene_tlas, flags, 0xffu, ray.o, tmin, ray.d, ray.tmax);
    while (rayQueryProceedEXT(q)) {
        uint prim = uint(rayQueryGetIntersectionPrimitiveIndexEXT(q, false));
        if (rayQueryGetIntersectionTypeEXT(q, false) == gl_RayQueryCandidateIntersectionAABBEXT) {
            // A sphere's box: the sphere test, up to the nearest hit committed so far.
            Ray r = ray;
            r.tmax = hit.t;
            float t = intersect_sphere(r, SPHERE(prim));
            if (t > 0.0f) {
                rayQueryGenerateIntersectionEXT(q, t);
                hit.t = t;
            }
        } else if (masks) {
            // A triangle of a scene with cut-outs: kept where its material is opaque.
            vec2 b = rayQueryGetIntersectionBarycentricsEXT(q, false);
            if (opaque_at(SCENE_ARGS_ TRIANGLE(prim).material, prim, b.x, b.y)) {
                rayQueryConfirmIntersectionEXT(q);
                hit.t = rayQueryGetIntersectionTEXT(q, false);
            }
        }
    }
    uint kind = rayQueryGetIntersectionTypeEXT(q, true);
    if (kind == gl_RayQueryCommittedIntersectionNoneEXT) return hit;
    hit.t = rayQueryGetIntersectionTEXT(q, true);
    uint prim = uint(rayQueryGetIntersectionPrimitiveIndexEXT(q, true));
    if (kind == gl_RayQueryCommittedIntersectionGeneratedEXT) {
        hit.prim = prim | SPHERE_BIT;
    } else {
        vec2 b = rayQueryGetIntersectionBarycentricsEXT(q, true);
        hit.b1 = b.x;
        hit.b2 = b.y;
        hit.prim = prim;
    }
    return hit;
}

MCPT_NAMESPACE_END

#endif  // MCPT_GPU_TRAVERSE_RAYQUERY_H
