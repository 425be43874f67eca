// Rays cast one by one for the oracle tests of the device traversals (GpuParams.ray_cast): ray
// i of a scene is a function of i alone, so the C++ build (cpu_trace.h) casts the very rays a
// device casts, and compares each device hit with brute force. Half the rays aim at a point
// on a triangle (hits, grazing ones and shared edges among them), the rest leave a random
// point of the scene's box in a random direction (misses and far hits).
#ifndef MCPT_GPU_RAY_CAST_H
#define MCPT_GPU_RAY_CAST_H

#include "intersect.h"
#include "rng.h"
#include "scene_access.h"

MCPT_NAMESPACE_BEGIN

// Ray i: from a point of the scene's box grown by a quarter on each side, toward a random
// point of triangle i / 2 (modulo their number) for even i, else in a uniform direction.
MCPT_FN Ray cast_ray(SCENE_PARAMS_ uint i) {
    vec4 u = rng4(i, 0u, 0u, 0x5eedu);
    vec4 v = rng4(i, 0u, 1u, 0x5eedu);
    vec3 lo = V3(PARAM(scene_min_x), PARAM(scene_min_y), PARAM(scene_min_z));
    vec3 hi = V3(PARAM(scene_max_x), PARAM(scene_max_y), PARAM(scene_max_z));
    vec3 margin = (hi - lo) * 0.25f;
    Ray r;
    r.o = lo - margin + (hi - lo + margin * 2.0f) * V3(u.x, u.y, u.z);
    r.tmax = MCPT_FLT_MAX;
    uint n = PARAM(num_triangles);
    if ((i & 1u) == 0u && n > 0u) {
        GpuTriangle t = TRIANGLE((i / 2u) % n);
        // A uniform point of the triangle (edges included, where the rounding of a and b
        // puts it).
        float a = v.x, b = v.y;
        if (a + b > 1.0f) {
            a = 1.0f - a;
            b = 1.0f - b;
        }
        vec3 p = tri_v0(t) + (tri_v1(t) - tri_v0(t)) * a + (tri_v2(t) - tri_v0(t)) * b;
        r.d = p - r.o;
    } else {
        float z = 1.0f - 2.0f * v.x, phi = 6.2831853f * v.y;
        float s = sqrt(MAXF(0.0f, 1.0f - z * z));
        r.d = V3(s * COSF(phi), s * SINF(phi), z);
    }
    if (dot(r.d, r.d) == 0.0f) r.d = V3(0.0f, 0.0f, 1.0f);
    return r;
}

MCPT_NAMESPACE_END

#endif  // MCPT_GPU_RAY_CAST_H
