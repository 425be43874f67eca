#include "accel_cases.h"

#include <cmath>
#include <cstdio>
#include <random>

namespace mcpt {

using glm::vec3;

// ---------------------------------------------------------------- meshes

Triangle tri(vec3 a, vec3 b, vec3 c) {
    return Triangle{a, b, c, 0};
}

// Random triangles of mixed sizes in the unit cube.
std::vector<Triangle> random_soup(int n, uint32_t seed) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> u(0.f, 1.f);
    std::vector<Triangle> t;
    for (int i = 0; i < n; ++i) {
        const vec3 c(u(rng), u(rng), u(rng));
        const float size = i % 10 == 0 ? 0.5f : 0.05f;
        const auto corner = [&] {
            return c + size * vec3(u(rng) - 0.5f, u(rng) - 0.5f, u(rng) - 0.5f);
        };
        t.push_back(tri(corner(), corner(), corner()));
    }
    return t;
}

// A bumpy closed surface: a cube-sphere with 12 n^2 triangles of similar size.
std::vector<Triangle> blob(int n, float bump) {
    std::vector<Triangle> t;
    for (int face = 0; face < 6; ++face) {
        const int axis = face % 3;
        const float sign = face < 3 ? 1.f : -1.f;
        const auto point = [&](int i, int j) {
            vec3 p;
            p[axis] = sign;
            p[(axis + 1) % 3] = (-1.f + 2.f * float(i) / float(n)) * sign;
            p[(axis + 2) % 3] = -1.f + 2.f * float(j) / float(n);
            const vec3 d = glm::normalize(p);
            const float r = 1.f + bump * std::sin(7.f * d.x + 1.f) * std::sin(5.f * d.y + 2.f) *
                                      std::sin(6.f * d.z);
            return d * r;
        };
        for (int j = 0; j < n; ++j) {
            for (int i = 0; i < n; ++i) {
                t.push_back(tri(point(i, j), point(i + 1, j), point(i + 1, j + 1)));
                t.push_back(tri(point(i, j), point(i + 1, j + 1), point(i, j + 1)));
            }
        }
    }
    return t;
}

// Stairs: treads and risers on integer planes, where split candidates lie.
std::vector<Triangle> stairs(int steps) {
    std::vector<Triangle> t;
    const auto quad = [&](vec3 a, vec3 b, vec3 c, vec3 d) {
        t.push_back(tri(a, b, c));
        t.push_back(tri(a, c, d));
    };
    for (int k = 0; k < steps; ++k) {
        const float y = float(k), z = float(k);
        quad({0, y, z}, {4, y, z}, {4, y, z + 1}, {0, y, z + 1});                  // tread
        quad({0, y, z + 1}, {4, y, z + 1}, {4, y + 1, z + 1}, {0, y + 1, z + 1});  // riser
    }
    return t;
}

// A jittered grid in the plane z = 0.5: zero-thickness bounds.
std::vector<Triangle> flat_grid(int n) {
    std::mt19937 rng(5);
    std::uniform_real_distribution<float> u(-0.3f, 0.3f);
    std::vector<vec3> v;
    for (int j = 0; j <= n; ++j) {
        for (int i = 0; i <= n; ++i) {
            const bool inner = i > 0 && j > 0 && i < n && j < n;
            v.push_back(
                {float(i) + (inner ? u(rng) : 0.f), float(j) + (inner ? u(rng) : 0.f), 0.5f});
        }
    }
    std::vector<Triangle> t;
    const auto at = [&](int i, int j) { return v[size_t(j * (n + 1) + i)]; };
    for (int j = 0; j < n; ++j) {
        for (int i = 0; i < n; ++i) {
            t.push_back(tri(at(i, j), at(i + 1, j), at(i + 1, j + 1)));
            t.push_back(tri(at(i, j), at(i + 1, j + 1), at(i, j + 1)));
        }
    }
    return t;
}

// The same triangle `count` times.
std::vector<Triangle> stacked(int count) {
    return std::vector<Triangle>(size_t(count),
                                 tri({0.2f, 0.1f, 0.3f}, {0.9f, 0.4f, 0.5f}, {0.4f, 0.8f, 0.35f}));
}

std::vector<NamedMesh> test_meshes() {
    std::vector<Triangle> mixed = blob(8);
    const std::vector<Triangle> pile = stacked(40);
    mixed.insert(mixed.end(), pile.begin(), pile.end());
    return {{"soup", random_soup(400, 1)}, {"blob", blob(10)},         {"stairs", stairs(8)},
            {"flat", flat_grid(16)},       {"stacked", stacked(1000)}, {"blob+pile", mixed}};
}

Bounds bounds_of(const std::vector<Triangle>& tris) {
    Bounds b;
    for (const Triangle& t : tris) b.extend(t.v0), b.extend(t.v1), b.extend(t.v2);
    return b;
}

// ---------------------------------------------------------------- rays

// Random rays aimed into the bounds, axis-aligned rays (zero components of both signs, some
// starting on integer planes), rays lying in integer planes, rays through vertices and rays
// along edges.
std::vector<TestRay> test_rays(const std::vector<Triangle>& tris, uint32_t seed) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> u(0.f, 1.f);
    const Bounds b = bounds_of(tris);
    const vec3 lo = b.min - 0.25f * (b.max - b.min) - 0.1f;
    const vec3 hi = b.max + 0.25f * (b.max - b.min) + 0.1f;
    const auto in_box = [&](vec3 a, vec3 c) { return a + (c - a) * vec3(u(rng), u(rng), u(rng)); };
    std::vector<TestRay> rays;
    // Random rays from around the bounds toward points inside.
    for (int i = 0; i < 120; ++i) {
        const vec3 o = in_box(lo, hi);
        vec3 d = in_box(b.min, b.max) - o;
        if (glm::length(d) == 0.f) d = vec3(0.3f, 0.5f, -0.8f);
        rays.push_back({o, glm::normalize(d)});
    }
    // Axis-aligned rays; the other components are exactly +0 or -0.
    for (int i = 0; i < 60; ++i) {
        vec3 o = in_box(lo, hi);
        if (i % 3 == 0) o = glm::floor(o);  // on integer planes (stairs faces, grid lines)
        if (i % 3 == 1 && !tris.empty()) o[i % 2] = tris[size_t(i) % tris.size()].v1[i % 2];
        vec3 d(i % 2 ? -0.f : 0.f, (i / 2) % 2 ? -0.f : 0.f, (i / 4) % 2 ? -0.f : 0.f);
        d[i % 3] = (i / 3) % 2 ? 1.f : -1.f;
        rays.push_back({o, d});
    }
    // Lying in an integer plane (stairs faces, the blob's vertex rows at 0): d[axis] = +-0.
    for (int i = 0; i < 60; ++i) {
        const int axis = i % 3;
        vec3 o = in_box(lo, hi), d = in_box(b.min, b.max) - o;
        o[axis] = std::round(o[axis]);
        d[axis] = (i / 3) % 2 ? -0.f : 0.f;
        if (glm::length(d) > 0.f) rays.push_back({o, glm::normalize(d)});
    }
    if (tris.empty()) return rays;
    // Through vertices, from random origins.
    for (int i = 0; i < 50; ++i) {
        const Triangle& t = tris[size_t(rng()) % tris.size()];
        const vec3 target = i % 3 == 0 ? t.v0 : (i % 3 == 1 ? t.v1 : t.v2);
        const vec3 o = in_box(lo, hi);
        if (o != target) rays.push_back({o, glm::normalize(target - o)});
    }
    // Along edges, starting before the edge.
    for (int i = 0; i < 30; ++i) {
        const Triangle& t = tris[size_t(rng()) % tris.size()];
        const vec3 e = i % 2 ? t.v1 - t.v0 : t.v2 - t.v1;
        const vec3 start = i % 2 ? t.v0 : t.v1;
        if (glm::length(e) > 0.f) rays.push_back({start - 0.5f * e, glm::normalize(e)});
    }
    return rays;
}

// The triangles as the device reads them (material 0).
std::vector<gpu::GpuTriangle> device_triangles(const std::vector<Triangle>& tris) {
    std::vector<gpu::GpuTriangle> g;
    for (const Triangle& t : tris)
        g.push_back({t.v0.x, t.v0.y, t.v0.z, t.v1.x, t.v1.y, t.v1.z, t.v2.x, t.v2.y, t.v2.z, 0u});
    return g;
}

std::string describe_ray(const TestRay& r) {
    char buf[200];
    std::snprintf(buf, sizeof buf, "ray (%.9g, %.9g, %.9g) -> (%.9g, %.9g, %.9g)", r.o.x, r.o.y,
                  r.o.z, r.d.x, r.d.y, r.d.z);
    return buf;
}

}  // namespace mcpt
