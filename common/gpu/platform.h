// The declaring half of the device dialect: which language compiles this file, its vector
// types, and the MCPT_-prefixed macros for structs, functions, namespaces and buffers
// (MCPT_PRECISE: a value computed exactly as written, without fused multiply-adds). Host
// code that needs the shared structs (shared_types.h, ray_types.h) includes only this; the
// expression dialect (V3, F32, ABSF, ...) is in lang.h and stays inside device code.
#ifndef MCPT_GPU_PLATFORM_H
#define MCPT_GPU_PLATFORM_H

#if defined(__OPENCL_VERSION__) || defined(__OPENCL_C_VERSION__)
#define MCPT_OPENCL 1
#elif defined(GL_core_profile) || defined(VULKAN) || defined(MCPT_GLSL)
#ifndef MCPT_GLSL
#define MCPT_GLSL 1
#endif
#else
#define MCPT_CPP 1
#endif

// ---------------------------------------------------------------- C++ (GLM mirrors GLSL)
#if defined(MCPT_CPP)
// The C++ build always counts traversal work (mcpt tree reports it; one definition only).
#define MCPT_COUNTERS 1
#include <glm/glm.hpp>

#include <cmath>
#include <cstdint>
#include <cstring>
namespace mcpt::gpu {
using uint = uint32_t;
using glm::vec2;
using glm::vec3;
using glm::vec4;
using glm::uvec2;
using glm::uvec4;
using glm::clamp;
using glm::cross;
using glm::dot;
using glm::length;
using glm::max;
using glm::min;
using glm::mix;
using glm::normalize;
using std::abs;
using std::acos;
using std::exp;
using std::floor;
using std::pow;
using std::sqrt;
inline float inversesqrt(float x) { return 1.0f / std::sqrt(x); }
inline uint float_as_uint(float f) { uint u; std::memcpy(&u, &f, 4); return u; }
inline float uint_as_float(uint u) { float f; std::memcpy(&f, &u, 4); return f; }
inline float fmax3(float a, float b, float c) { return std::max(a, std::max(b, c)); }
}  // namespace mcpt::gpu
#define MCPT_FN inline
#define MCPT_FN_CALLED inline
#define MCPT_STRUCT(name) struct name
#define MCPT_NAMESPACE_BEGIN namespace mcpt::gpu {
#define MCPT_NAMESPACE_END }
#define MCPT_GLOBAL
#define MCPT_CONST_BUF const
#define MCPT_PRECISE  // the build compiles with -ffp-contract=off
// A table of constants (C++ and OpenCL C; not GLSL, where drivers may compile a large one
// into a chain of selects): MCPT_TABLE(float, NAME, n) v0, v1, ... MCPT_TABLE_END;
#define MCPT_TABLE(type, name, n) inline constexpr type name[n] = {
#define MCPT_TABLE_END }

// ---------------------------------------------------------------- OpenCL C
#elif defined(MCPT_OPENCL)
#define vec2 float2
#define vec3 float3
#define vec4 float4
#define uvec2 uint2
#define uvec4 uint4
// Every device function inlined: PoCL otherwise calls the triangle test and the traversal,
// passing their structs through memory (+28 to +37% with them inlined); NVIDIA inlines them
// anyway (no change there).
#define MCPT_FN inline __attribute__((always_inline))
// A few hot functions whose arguments and result travel in registers (no struct) are called
// on CPU devices instead (MCPT_OUT_OF_LINE): PoCL ran 4-12% faster with the Sobol sampler and
// the child-box test out of line, NVIDIA's OpenCL up to 10% slower (docs/traversal.md, "PoCL:
// the sampler and the child-box test called").
#if defined(MCPT_OUT_OF_LINE)
#define MCPT_FN_CALLED __attribute__((noinline))
#else
#define MCPT_FN_CALLED MCPT_FN
#endif
#define MCPT_STRUCT(name) \
    typedef struct name name; \
    struct name
#define MCPT_NAMESPACE_BEGIN
#define MCPT_NAMESPACE_END
#define MCPT_GLOBAL __global
#define MCPT_CONST_BUF __global const
#define MCPT_PRECISE  // the OpenCL sources turn FP_CONTRACT off where it matters
#define MCPT_TABLE(type, name, n) __constant type name[n] = {
#define MCPT_TABLE_END }

// ---------------------------------------------------------------- GLSL (Vulkan)
#else
#define MCPT_FN
#define MCPT_FN_CALLED
#define MCPT_STRUCT(name) struct name
#define MCPT_NAMESPACE_BEGIN
#define MCPT_NAMESPACE_END
#define MCPT_GLOBAL
#define MCPT_CONST_BUF
#define MCPT_PRECISE precise  // SPIR-V NoContraction: no fused multiply-add
#endif

#endif  // MCPT_GPU_PLATFORM_H
