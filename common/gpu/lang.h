// One device dialect for C++ (tests, CPU tools), OpenCL C (kernels/) and GLSL (shaders/).
//
// Shared device code is written in the common subset of the three languages: GLSL-style
// vector math (vec3, dot, cross), explicit casts through F32()/U32()/I32(), constructors
// through V3()/V3S(), no pointers, no out-parameters (functions return structs instead).
// Buffers are reached through the names in SCENE_PARAMS/SCENE_ARGS: kernel arguments in
// OpenCL C and C++, global storage blocks in GLSL.
#ifndef MCPT_GPU_LANG_H
#define MCPT_GPU_LANG_H

#include "platform.h"

// ---------------------------------------------------------------- C++
#if defined(MCPT_CPP)
#define V2(x, y) vec2(float(x), float(y))
#define V3(x, y, z) vec3(float(x), float(y), float(z))
#define V3S(s) vec3(float(s))
#define V4(x, y, z, w) vec4(float(x), float(y), float(z), float(w))
#define V4S(s) vec4(float(s))
#define UV4(x, y, z, w) uvec4(uint(x), uint(y), uint(z), uint(w))
#define UV2(x, y) uvec2(uint(x), uint(y))
#define F32(x) float(x)
#define U32(x) uint(x)
#define I32(x) int(x)
#define ABSF(x) std::fabs(x)
#define VABS(v) glm::abs(v)
#define MINF(a, b) std::fmin(a, b)
#define MAXF(a, b) std::fmax(a, b)
#define ATAN2(y, x) std::atan2(y, x)
#define SINF(x) std::sin(x)
#define COSF(x) std::cos(x)
#define DIVF(a, b) ((a) / (b))
#define SELECT3(a, b, c) ((c) ? (b) : (a))
#define FIND_MSB(x) uint(31 - __builtin_clz(x))  // x != 0
#define BIT_COUNT(x) uint(__builtin_popcount(x))
#define NO_UNROLL  // before a loop the compiler should keep rolled (code size)
#define AS_VEC4(q) \
    vec4(uint_as_float((q).x), uint_as_float((q).y), uint_as_float((q).z), uint_as_float((q).w))

// ---------------------------------------------------------------- OpenCL C
#elif defined(MCPT_OPENCL)
#define V2(x, y) ((float2)((float)(x), (float)(y)))
#define V3(x, y, z) ((float3)((float)(x), (float)(y), (float)(z)))
#define V3S(s) ((float3)((float)(s)))
#define V4(x, y, z, w) ((float4)((float)(x), (float)(y), (float)(z), (float)(w)))
#define V4S(s) ((float4)((float)(s)))
#define UV4(x, y, z, w) ((uint4)((uint)(x), (uint)(y), (uint)(z), (uint)(w)))
#define UV2(x, y) ((uint2)((uint)(x), (uint)(y)))
#define F32(x) ((float)(x))
#define U32(x) ((uint)(x))
#define I32(x) ((int)(x))
#define ABSF(x) fabs(x)
#define VABS(v) fabs(v)
#define MINF(a, b) fmin(a, b)
#define MAXF(a, b) fmax(a, b)
#define ATAN2(y, x) atan2(y, x)
// NVIDIA: sine and cosine from the hardware's approximations, as its GLSL compiler gives them
// (absolute error about 1e-6 over the sampling's [0, 2 pi)): +14% on the materials scene, +4%
// on the textured one (docs/benchmarks.md).
#if defined(MCPT_NVIDIA_OPENCL)
#define SINF(x) native_sin(x)
#define COSF(x) native_cos(x)
#else
#define SINF(x) sin(x)
#define COSF(x) cos(x)
#endif
// DIVF(a, b): a / b to GLSL's precision (2.5 ulp for |b| in [2^-126, 2^126]), for shading,
// sampling and sphere hits. NVIDIA: 1 / b, which its OpenCL already takes from the hardware's
// approximate reciprocal, times a, in place of OpenCL's full-range a / b (div.full: operands
// beyond 2^126 scaled first): +8% on the materials scene (docs/benchmarks.md). native_divide
// was no faster (it ignores -cl-denorms-are-zero). Every other device: exactly a / b. Ratios
// bounded by 1 that a comparison or a sqrt(1 - x) relies on keep `/` (probabilities, uniforms
// rescaled for reuse, a cone's sin^2): exact on CPU devices, as before on NVIDIA.
#if defined(MCPT_NVIDIA_OPENCL)
#define DIVF(a, b) ((a) * (1.0f / (b)))
#else
#define DIVF(a, b) ((a) / (b))
#endif
#define inversesqrt(x) rsqrt(x)
// NVIDIA: normalize and length as GLSL defines them, without OpenCL's rescaling against
// overflow and underflow (vectors beyond 1e19 or below 1e-19, which the tracer never forms):
// that guard cost 8% of the Cornell box's speed and 20-23% of the materials and the textured
// scene's there (docs/benchmarks.md). PoCL's own are faster than these (5% on materials).
#if defined(MCPT_NVIDIA_OPENCL)
#define normalize(v) ((v)*rsqrt(dot((v), (v))))
#define length(v) sqrt(dot((v), (v)))
#endif
#define float_as_uint(x) as_uint(x)
#define uint_as_float(x) as_float(x)
#define fmax3(a, b, c) fmax(a, fmax(b, c))
#define SELECT3(a, b, c) ((c) ? (b) : (a))
#define FIND_MSB(x) (31u - clz(x))
#define BIT_COUNT(x) popcount(x)
#define NO_UNROLL _Pragma("unroll 1")
#define AS_VEC4(q) as_float4(q)

// ---------------------------------------------------------------- GLSL (Vulkan)
#else
#define V2(x, y) vec2(float(x), float(y))
#define V3(x, y, z) vec3(float(x), float(y), float(z))
#define V3S(s) vec3(float(s))
#define V4(x, y, z, w) vec4(float(x), float(y), float(z), float(w))
#define V4S(s) vec4(float(s))
#define UV4(x, y, z, w) uvec4(uint(x), uint(y), uint(z), uint(w))
#define UV2(x, y) uvec2(uint(x), uint(y))
#define F32(x) float(x)
#define U32(x) uint(x)
#define I32(x) int(x)
#define ABSF(x) abs(x)
#define VABS(v) abs(v)
#define MINF(a, b) min(a, b)
#define MAXF(a, b) max(a, b)
#define ATAN2(y, x) atan(y, x)
#define SINF(x) sin(x)
#define COSF(x) cos(x)
#define DIVF(a, b) ((a) / (b))
#define float_as_uint(x) floatBitsToUint(x)
#define uint_as_float(x) uintBitsToFloat(x)
#define fmax3(a, b, c) max(a, max(b, c))
#define SELECT3(a, b, c) ((c) ? (b) : (a))
#define FIND_MSB(x) uint(findMSB(x))
#define BIT_COUNT(x) uint(bitCount(x))
#define NO_UNROLL [[dont_unroll]]  // GL_EXT_control_flow_attributes (shaders/pathtrace.comp)
#define AS_VEC4(q) uintBitsToFloat(q)
#endif

#endif  // MCPT_GPU_LANG_H
