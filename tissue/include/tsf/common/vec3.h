// Small POD vector types usable in CUDA kernels and CPU loops alike.
//
// Vec3f  3 floats (positions in mm, velocities in mm/s, forces in N·mm/s²·g … see each caller)
// Vec3d  3 doubles for geometry bookkeeping on the host (origins, spacings in mm)
// Int3   3 ints (grid indices and dimensions)
// All are trivially copyable so they can be memcpy'd to the GPU and passed to kernels by value.
#pragma once

#include <cmath>
#include <cstdint>

#include "tsf/common/hd.h"

namespace tsf {

struct Int3 {
  int x = 0, y = 0, z = 0;
  TSF_HD_INLINE int& operator[](int i) { return i == 0 ? x : (i == 1 ? y : z); }
  TSF_HD_INLINE int operator[](int i) const { return i == 0 ? x : (i == 1 ? y : z); }
  TSF_HD_INLINE bool operator==(const Int3& o) const { return x == o.x && y == o.y && z == o.z; }
  TSF_HD_INLINE bool operator!=(const Int3& o) const { return !(*this == o); }
  /// Number of cells x*y*z as a 64-bit count (volumes of 512³ and more overflow int).
  TSF_HD_INLINE std::int64_t volume() const {
    return static_cast<std::int64_t>(x) * static_cast<std::int64_t>(y) *
           static_cast<std::int64_t>(z);
  }
};

template <typename T>
struct Vec3 {
  T x = 0, y = 0, z = 0;

  TSF_HD_INLINE T& operator[](int i) { return i == 0 ? x : (i == 1 ? y : z); }
  TSF_HD_INLINE T operator[](int i) const { return i == 0 ? x : (i == 1 ? y : z); }
  TSF_HD_INLINE Vec3 operator+(const Vec3& o) const { return {x + o.x, y + o.y, z + o.z}; }
  TSF_HD_INLINE Vec3 operator-(const Vec3& o) const { return {x - o.x, y - o.y, z - o.z}; }
  TSF_HD_INLINE Vec3 operator-() const { return {-x, -y, -z}; }
  TSF_HD_INLINE Vec3 operator*(T s) const { return {x * s, y * s, z * s}; }
  TSF_HD_INLINE Vec3 operator/(T s) const { return {x / s, y / s, z / s}; }
  TSF_HD_INLINE Vec3& operator+=(const Vec3& o) {
    x += o.x;
    y += o.y;
    z += o.z;
    return *this;
  }
  TSF_HD_INLINE Vec3& operator-=(const Vec3& o) {
    x -= o.x;
    y -= o.y;
    z -= o.z;
    return *this;
  }
  TSF_HD_INLINE Vec3& operator*=(T s) {
    x *= s;
    y *= s;
    z *= s;
    return *this;
  }
  TSF_HD_INLINE bool operator==(const Vec3& o) const { return x == o.x && y == o.y && z == o.z; }
  TSF_HD_INLINE bool operator!=(const Vec3& o) const { return !(*this == o); }
};

template <typename T>
TSF_HD_INLINE Vec3<T> operator*(T s, const Vec3<T>& v) {
  return v * s;
}
template <typename T>
TSF_HD_INLINE T dot(const Vec3<T>& a, const Vec3<T>& b) {
  return a.x * b.x + a.y * b.y + a.z * b.z;
}
template <typename T>
TSF_HD_INLINE Vec3<T> cross(const Vec3<T>& a, const Vec3<T>& b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
template <typename T>
TSF_HD_INLINE Vec3<T> cwise_mul(const Vec3<T>& a, const Vec3<T>& b) {
  return {a.x * b.x, a.y * b.y, a.z * b.z};
}
template <typename T>
TSF_HD_INLINE T length_squared(const Vec3<T>& a) {
  return dot(a, a);
}
TSF_HD_INLINE float length(const Vec3<float>& a) {
  return sqrtf(dot(a, a));
}
TSF_HD_INLINE double length(const Vec3<double>& a) {
  return sqrt(dot(a, a));
}
/// a/|a|, or the zero vector when |a| is below `eps` (callers decide what a zero direction means).
template <typename T>
TSF_HD_INLINE Vec3<T> normalized_or_zero(const Vec3<T>& a, T eps = T(1e-20)) {
  const T l = length(a);
  return l > eps ? a / l : Vec3<T>{};
}
template <typename T>
TSF_HD_INLINE bool all_finite(const Vec3<T>& a) {
#if defined(__CUDA_ARCH__)
  return isfinite(a.x) && isfinite(a.y) && isfinite(a.z);
#else
  // <cmath> removes C's isfinite macro and declares only std::isfinite on the host.
  return std::isfinite(a.x) && std::isfinite(a.y) && std::isfinite(a.z);
#endif
}

using Vec3f = Vec3<float>;
using Vec3d = Vec3<double>;

TSF_HD_INLINE Vec3f to_float(const Vec3d& v) {
  return {static_cast<float>(v.x), static_cast<float>(v.y), static_cast<float>(v.z)};
}
TSF_HD_INLINE Vec3d to_double(const Vec3f& v) {
  return {v.x, v.y, v.z};
}

}  // namespace tsf
