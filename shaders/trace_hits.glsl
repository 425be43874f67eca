// The ray-tracing pipeline's other shaders (--tree raypipeline; the ray-generation shader is
// pathtrace.comp built with MCPT_RAY_PIPELINE, whose trace_ray() in traverse_driver.h reads
// the payload). One source, built once per stage with its MCPT_STAGE_* define:
//  - CLOSEST_HIT: the payload (t, prim, b1, b2) of the nearest hit, a triangle's or a sphere's;
//  - MISS: prim = NO_HIT;
//  - ANY_HIT: a triangle's candidate kept where its material is opaque (alpha masks; the
//    triangles are non-opaque only in scenes with some, so it runs nowhere else);
//  - SPHERE: the intersection shader of a sphere's box, our own sphere test.
#version 460
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_control_flow_attributes : require
#extension GL_EXT_ray_tracing : require
#define MCPT_GLSL 1
#include "../common/gpu/intersect.h"
#include "../common/gpu/texture.h"

#if defined(MCPT_STAGE_CLOSEST_HIT) || defined(MCPT_STAGE_MISS)
layout(location = 0) rayPayloadInEXT vec4 trace_payload;
#endif
#if !defined(MCPT_STAGE_MISS)
hitAttributeEXT vec2 hit_barycentrics;  // a triangle's (v1, v2); unused by spheres
#endif

#if defined(MCPT_STAGE_CLOSEST_HIT) || defined(MCPT_STAGE_ANY_HIT)
// The triangle or sphere hit: its instance's first primitive plus its index within it (as
// driver_prim() in traverse_driver.h, which these stages do not include).
uint hit_prim() {
    return uint(gl_InstanceCustomIndexEXT + gl_PrimitiveID);
}
#endif

void main() {
#if defined(MCPT_STAGE_CLOSEST_HIT)
    // Triangles report the hit kinds 0xFE and 0xFF (front or back face), spheres 0.
    uint prim = hit_prim();
    if (gl_HitKindEXT < gl_HitKindFrontFacingTriangleEXT)
        trace_payload = vec4(gl_HitTEXT, uint_as_float(prim | SPHERE_BIT), 0.0f, 0.0f);
    else
        trace_payload =
            vec4(gl_HitTEXT, uint_as_float(prim), hit_barycentrics.x, hit_barycentrics.y);
#elif defined(MCPT_STAGE_MISS)
    trace_payload.y = uint_as_float(NO_HIT);
#elif defined(MCPT_STAGE_ANY_HIT)
    uint prim = hit_prim();
    if (!opaque_at(TRIANGLE(prim).material, prim, hit_barycentrics.x, hit_barycentrics.y))
        ignoreIntersectionEXT;
#elif defined(MCPT_STAGE_SPHERE)
    // The nearest root before the nearest hit so far; the driver drops it below tmin.
    Ray ray;
    ray.o = gl_WorldRayOriginEXT;
    ray.d = gl_WorldRayDirectionEXT;
    ray.tmax = gl_RayTmaxEXT;
    float t = intersect_sphere(ray, SPHERE(uint(gl_PrimitiveID)));
    if (t > 0.0f) {
        hit_barycentrics = vec2(0.0f);
        reportIntersectionEXT(t, 0u);
    }
#endif
}
