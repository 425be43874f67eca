// What the traversal and the path tracer take and return: rays, hits and path results.
// Plain data in the declaring dialect only (platform.h), so host code (cpu_trace.h) can
// hold them without the expression macros of lang.h.
#ifndef MCPT_GPU_RAY_TYPES_H
#define MCPT_GPU_RAY_TYPES_H

#include "platform.h"
#if defined(MCPT_CPP)
#include <cstdint>
#include <vector>
#endif

MCPT_NAMESPACE_BEGIN

#define MCPT_FLT_MAX 3.402823466e+38f

// Hit.prim: no hit, or a sphere (the index with SPHERE_BIT set).
#define NO_HIT 0xffffffffu
#define SPHERE_BIT 0x80000000u

// Hit.status: the query is unreliable and its sample is discarded.
#define TRACE_STACK_OVERFLOW 1u
// A loop ended early without reaching its exit: some drivers cut loops after a fixed number of
// iterations per invocation (llvmpipe/lavapipe: 65,535, shared by every loop of the shader).
#define TRACE_INCOMPLETE 2u

MCPT_STRUCT(Ray) {
    vec3 o;
    vec3 d;
    float tmax;
};

MCPT_STRUCT(Hit) {
    float t;
    float b1, b2;  // barycentrics of v1, v2 on a triangle hit
    uint prim;     // triangle index, sphere index | SPHERE_BIT, or NO_HIT
    uint status;   // 0, TRACE_STACK_OVERFLOW or TRACE_INCOMPLETE (the query is unreliable)
    uint tri_tests, node_visits;  // counted when MCPT_COUNTERS is defined
};

MCPT_STRUCT(PathResult) {
    vec3 radiance;
    uint rays;  // rays traced (camera, bounce and shadow rays)
};

#if defined(MCPT_CPP)
// Traversal work summed over rays; the C++ build counts it (mcpt tree, mcpt bench).
struct RayWork {
    double rays = 0, hits = 0, tri_tests = 0, node_visits = 0;
    bool keep_visits = false;                // log each ray's node visits, in the order traced
    std::vector<uint32_t> visits_per_trace;  // (cpu_path_visits: a model of a GPU warp)
    void add(const Hit& h) {
        rays += 1, hits += h.prim != NO_HIT, tri_tests += h.tri_tests, node_visits += h.node_visits;
        if (keep_visits) visits_per_trace.push_back(h.node_visits);
    }
    void add(const RayWork& w) {
        rays += w.rays, hits += w.hits, tri_tests += w.tri_tests, node_visits += w.node_visits;
    }
    double tests_per_ray() const { return rays > 0 ? tri_tests / rays : 0; }
    double visits_per_ray() const { return rays > 0 ? node_visits / rays : 0; }
};
#endif

MCPT_NAMESPACE_END

#endif  // MCPT_GPU_RAY_TYPES_H
