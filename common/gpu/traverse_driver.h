// Closest-hit and any-hit queries handed to the driver (GLSL only): the trace modes beside the
// k-d tree (traverse.h) and the wide BVH (traverse_bvh.h), with the same trace_ray() contract,
// in one of two forms:
//  - ray queries (GL_EXT_ray_query; the compute module built with MCPT_RAY_QUERY; --tree
//    rayquery): the loop below decides cut-outs and spheres itself;
//  - the ray-tracing pipeline (GL_EXT_ray_tracing; pathtrace.comp built as a ray-generation
//    shader with MCPT_RAY_PIPELINE; --tree raypipeline): traceRayEXT, with the hit-group
//    shaders of shaders/trace_hits.glsl filling the payload, deciding cut-outs (any-hit) and
//    testing spheres (intersection).
// The host builds one top-level structure over bottom-level ones (vk_accel.cpp): the triangles
// in index order, in runs that are all opaque or all non-opaque (a material with an alpha
// mask), each instance's custom index its first triangle; and one box per sphere (procedural,
// our sphere test). Ties
// between triangles at one distance resolve as the driver orders them, not by index as the
// software traversals do.
#ifndef MCPT_GPU_TRAVERSE_DRIVER_H
#define MCPT_GPU_TRAVERSE_DRIVER_H

MCPT_NAMESPACE_BEGIN

// tmin, relative to the origin's largest coordinate: the driver's own triangle test hits the
// surface a ray leaves at tmin = 0 (docs/traversal.md).
#ifndef RQ_TMIN_REL
#define RQ_TMIN_REL (64.0f * MCPT_FLOAT_EPS)
#endif

layout(binding = BINDING_TLAS) uniform accelerationStructureEXT scene_tlas;

// A primitive's index in the scene: its instance's first (the custom index: triangles come in
// runs of opaque and cut-out ones, vk_accel.h) plus its index within the instance.
MCPT_FN uint driver_prim(int first, int index) {
    return uint(first + index);
}

// The ray's tmin in its own parameter (d need not be unit length).
MCPT_FN float driver_tmin(Ray ray) {
    vec3 ao = abs(ray.o);
    return RQ_TMIN_REL * max(max(ao.x, ao.y), ao.z) / length(ray.d);
}

#if defined(MCPT_RAY_PIPELINE)

// The payload the hit group and miss shader fill (trace_hits.glsl): t, the primitive (its bits:
// a triangle, a sphere | SPHERE_BIT or NO_HIT) and the barycentrics of v1 and v2.
layout(location = 0) rayPayloadEXT vec4 trace_payload;

// Nearest hit with t < ray.tmax; with any_hit, whether anything is hit (the trace ends at
// the first hit accepted and runs no closest-hit shader: prim is 0 for a hit, t is tmax).
MCPT_FN Hit trace_ray(SCENE_PARAMS_ Ray ray, bool any_hit) {
    uint flags = any_hit ? gl_RayFlagsTerminateOnFirstHitEXT | gl_RayFlagsSkipClosestHitShaderEXT
                         : gl_RayFlagsNoneEXT;
    trace_payload = vec4(ray.tmax, uint_as_float(0u), 0.0f, 0.0f);
    traceRayEXT(scene_tlas, flags, 0xffu, 0u, 0u, 0u, ray.o, driver_tmin(ray), ray.d, ray.tmax, 0);
    Hit hit = no_hit(ray.tmax);
    hit.prim = float_as_uint(trace_payload.y);
    if (hit.prim == NO_HIT) return hit;
    hit.t = trace_payload.x;
    hit.b1 = trace_payload.z;
    hit.b2 = trace_payload.w;
    return hit;
}

#else

// Nearest hit with t < ray.tmax; with any_hit, the first hit found (the query ends at the
// first one committed). Cut-outs (alpha masks) and spheres are decided in the query's loop.
MCPT_FN Hit trace_ray(SCENE_PARAMS_ Ray ray, bool any_hit) {
    bool masks = HAS_FEATURE(FEATURE_ALPHA_MASK) && (PARAM(scene_flags) & SCENE_ALPHA_MASK) != 0u;
    Hit hit = no_hit(ray.tmax);
    uint flags = any_hit ? gl_RayFlagsTerminateOnFirstHitEXT : gl_RayFlagsNoneEXT;
    rayQueryEXT q;
    rayQueryInitializeEXT(q, scene_tlas, flags, 0xffu, ray.o, driver_tmin(ray), ray.d, ray.tmax);
    while (rayQueryProceedEXT(q)) {
        uint prim = driver_prim(rayQueryGetIntersectionInstanceCustomIndexEXT(q, false),
                                rayQueryGetIntersectionPrimitiveIndexEXT(q, false));
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
    uint prim = driver_prim(rayQueryGetIntersectionInstanceCustomIndexEXT(q, true),
                            rayQueryGetIntersectionPrimitiveIndexEXT(q, true));
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

#endif  // MCPT_RAY_PIPELINE

MCPT_NAMESPACE_END

#endif  // MCPT_GPU_TRAVERSE_DRIVER_H
