// Forward-mode dual numbers: the implicit integrator's exact Jacobian of the CRMS force.
//
// node_force.h is a template over the scalar type; instantiated with Dual<N>, every operation
// also carries N partial derivatives, so ∂F/∂u and ∂F/∂v come from the very code the explicit
// kernels run (no second, hand-derived copy of the angular-spring derivatives to drift apart).
// Host only. Non-smooth points (clamps, selects) take the derivative of the branch taken.
#pragma once

#include <cfloat>
#include <cmath>

namespace tsf::crms {

template <int N>
struct Dual {
  double v = 0.0;
  double d[N] = {};

  Dual() = default;
  Dual(double value) : v(value) {}  // NOLINT: constants promote implicitly, as for double

  Dual operator-() const {
    Dual r;
    r.v = -v;
    for (int i = 0; i < N; ++i) r.d[i] = -d[i];
    return r;
  }
  Dual& operator+=(const Dual& o) {
    v += o.v;
    for (int i = 0; i < N; ++i) d[i] += o.d[i];
    return *this;
  }
  Dual& operator-=(const Dual& o) {
    v -= o.v;
    for (int i = 0; i < N; ++i) d[i] -= o.d[i];
    return *this;
  }
  Dual& operator*=(const Dual& o) {
    for (int i = 0; i < N; ++i) d[i] = d[i] * o.v + v * o.d[i];
    v *= o.v;
    return *this;
  }
  Dual& operator/=(const Dual& o) {
    const double inv = 1.0 / o.v;
    for (int i = 0; i < N; ++i) d[i] = (d[i] - v * inv * o.d[i]) * inv;
    v *= inv;
    return *this;
  }
  friend Dual operator+(Dual a, const Dual& b) { return a += b; }
  friend Dual operator-(Dual a, const Dual& b) { return a -= b; }
  friend Dual operator*(Dual a, const Dual& b) { return a *= b; }
  friend Dual operator/(Dual a, const Dual& b) { return a /= b; }
  friend bool operator<(const Dual& a, const Dual& b) { return a.v < b.v; }
  friend bool operator>(const Dual& a, const Dual& b) { return a.v > b.v; }
  friend bool operator<=(const Dual& a, const Dual& b) { return a.v <= b.v; }
  friend bool operator>=(const Dual& a, const Dual& b) { return a.v >= b.v; }
};

/// f(x) with derivative f'(x): chain rule onto every partial.
template <int N>
Dual<N> chain(const Dual<N>& x, double f, double df) {
  Dual<N> r;
  r.v = f;
  for (int i = 0; i < N; ++i) r.d[i] = df * x.d[i];
  return r;
}
template <int N>
Dual<N> crms_sqrt(const Dual<N>& x) {
  const double s = std::sqrt(x.v);
  return chain(x, s, s > 0.0 ? 0.5 / s : 0.0);
}
template <int N>
Dual<N> crms_asin(const Dual<N>& x) {
  const double one_minus = 1.0 - x.v * x.v;
  return chain(x, std::asin(x.v), one_minus > 0.0 ? 1.0 / std::sqrt(one_minus) : 0.0);
}
template <int N>
Dual<N> crms_max(const Dual<N>& a, const Dual<N>& b) {
  return a.v > b.v ? a : b;
}
template <int N>
Dual<N> crms_min(const Dual<N>& a, const Dual<N>& b) {
  return a.v < b.v ? a : b;
}
template <int N>
Dual<N> crms_abs(const Dual<N>& x) {
  return x.v < 0.0 ? -x : x;
}
template <int N>
bool crms_finite(const Dual<N>& x) {
  return std::fabs(x.v) <= DBL_MAX;
}

}  // namespace tsf::crms
