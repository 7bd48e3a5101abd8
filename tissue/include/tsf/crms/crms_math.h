// Scalar helpers for the one copy of the CRMS physics.
//
// The per-node functions are templates over the scalar type: float in the CPU and CUDA kernels,
// double for host-side energy sums, and a forward-mode dual number (dual.h) for the implicit
// integrator's exact Jacobian. Every transcendental the physics needs goes through these
// overloads so that each scalar type brings its own.
//
// float versions avoid libm calls where a call would stop the CPU loop from vectorizing:
// asin is the Cephes single-precision polynomial (≈1 ulp on [−1,1]), evaluated identically by
// g++ and nvcc, which also keeps the CPU and CUDA backends bit-close.
#pragma once

#include <cfloat>
#include <cmath>

#include "tsf/common/hd.h"
#include "tsf/common/vec3.h"

#if defined(__CUDA_ARCH__)
#define TSF_UNROLL _Pragma("unroll")
#elif defined(__CUDACC__)
#define TSF_UNROLL  // host pass of a .cu file: kernels are compiled in the device pass
#elif defined(__GNUC__) && !defined(__clang__)
#define TSF_UNROLL _Pragma("GCC unroll 32")
#elif defined(__clang__)
#define TSF_UNROLL _Pragma("unroll")
#else
#define TSF_UNROLL
#endif

namespace tsf::crms {

// ---- float ------------------------------------------------------------------------------------
TSF_HD_INLINE float crms_sqrt(float x) {
  return sqrtf(x);
}
TSF_HD_INLINE float crms_max(float a, float b) {
  return a > b ? a : b;
}
TSF_HD_INLINE float crms_min(float a, float b) {
  return a < b ? a : b;
}
TSF_HD_INLINE float crms_abs(float x) {
  return fabsf(x);
}
/// |x| ≤ FLT_MAX: false for NaN and ±Inf, and a plain compare the vectorizer understands.
TSF_HD_INLINE bool crms_finite(float x) {
  return fabsf(x) <= FLT_MAX;
}

/// asin(x) for x in [−1,1] (Cephes asinf: x + x·z·P(z) on |x| ≤ ½, π/2 − 2·asin(√((1−|x|)/2))
/// above). Branch-free: both halves share one polynomial.
TSF_HD_INLINE float crms_asin(float x) {
  const float a = fabsf(x);
  const bool big = a > 0.5f;
  const float z = big ? 0.5f * (1.0f - a) : a * a;
  const float s = big ? sqrtf(z) : a;
  const float p =
      ((((4.2163199048e-2f * z + 2.4181311049e-2f) * z + 4.5470025998e-2f) * z + 7.4953002686e-2f) *
           z +
       1.6666752422e-1f) *
      z;
  const float r = s + s * p;
  const float v = big ? 1.57079632679489662f - 2.0f * r : r;
  return x < 0.0f ? -v : v;
}

/// 1/√x and 1/x for x > 0. On the device these are the special-function unit's approximations
/// (≤ 2 ulp, one instruction each instead of the multi-instruction IEEE sequences), on the host
/// the correctly rounded operations; the physics only takes them of squared lengths and sums of
/// lengths that are clamped away from 0, so the difference stays at float rounding (the CPU/CUDA
/// parity test bounds it).
TSF_HD_INLINE float crms_rsqrt(float x) {
#if defined(__CUDA_ARCH__)
  return rsqrtf(x);
#else
  return 1.0f / sqrtf(x);
#endif
}
TSF_HD_INLINE float crms_rcp(float x) {
#if defined(__CUDA_ARCH__)
  return __fdividef(1.0f, x);
#else
  return 1.0f / x;
#endif
}

// ---- double -----------------------------------------------------------------------------------
TSF_HD_INLINE double crms_sqrt(double x) {
  return sqrt(x);
}
TSF_HD_INLINE double crms_max(double a, double b) {
  return a > b ? a : b;
}
TSF_HD_INLINE double crms_min(double a, double b) {
  return a < b ? a : b;
}
TSF_HD_INLINE double crms_abs(double x) {
  return fabs(x);
}
TSF_HD_INLINE bool crms_finite(double x) {
  return fabs(x) <= DBL_MAX;
}
TSF_HD_INLINE double crms_asin(double x) {
  return asin(x);
}

// ---- generic ----------------------------------------------------------------------------------
/// 1/√x and 1/x for double and dual numbers (float has its own overloads above).
template <typename T>
TSF_HD_INLINE T crms_rsqrt(const T& x) {
  return T(1) / crms_sqrt(x);
}
template <typename T>
TSF_HD_INLINE T crms_rcp(const T& x) {
  return T(1) / x;
}
template <typename T>
TSF_HD_INLINE T crms_clamp(T x, T lo, T hi) {
  return crms_min(crms_max(x, lo), hi);
}
/// v[axis] for a per-axis triple, by selects: a run-time axis then never forces the array (or the
/// kernel parameter block holding it) into local memory on the GPU.
TSF_HD_INLINE float axis_value(const float* v, int axis) {
  return axis == 0 ? v[0] : (axis == 1 ? v[1] : v[2]);
}
template <typename T>
TSF_HD_INLINE Vec3<T> select(bool c, const Vec3<T>& a, const Vec3<T>& b) {
  return {c ? a.x : b.x, c ? a.y : b.y, c ? a.z : b.z};
}
template <typename T>
TSF_HD_INLINE T crms_length(const Vec3<T>& a) {
  return crms_sqrt(dot(a, a));
}
template <typename T>
TSF_HD_INLINE bool crms_finite(const Vec3<T>& a) {
  return crms_finite(a.x) & crms_finite(a.y) & crms_finite(a.z);  // no branches
}

}  // namespace tsf::crms
