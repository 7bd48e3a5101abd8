// A point of the deformed world mapped back into rest space through the local lattice deformation
// (thesis §8.5.1): the haptic stylus is inverse-warped to where the voxels are (haptics), and a
// point near another tissue instance is mapped into that body's rest space, where its distance
// grid is (interaction/body_field.h). Per-point math, TSF_HD.
//
// The lattice window gives the displacement u at its nodes; inside a cube u is trilinear in the
// rest point X. The stylus centre p (deformed world) has rest point X with X + u(X) = p, found by
// the fixed-point iteration X ← p − u(X) (it converges while |∇u| < 1, i.e. short of a cube
// inverting). Around X the map is affine, x = p + F·(X' − X) with F = I + ∇u, so a stylus offset δ
// in the world is the rest offset F⁻¹·δ. Dead corners are left out of the interpolation (weights
// renormalised); no alive corner, or no window, is the identity warp.
#pragma once

#include <cmath>
#include <cstdint>

#include "tsf/common/hd.h"
#include "tsf/common/vec3.h"

namespace tsf::coupler {

/// Lattice nodes around a point (a window, or a whole small lattice): their displacement from
/// rest and whether they are alive.
struct LatticeWindowView {
  const Vec3f* displacement = nullptr;  ///< #nodes, mm
  const std::uint8_t* alive = nullptr;  ///< #nodes, 1 = node alive
  Int3 dims{0, 0, 0};
  Vec3d origin{0, 0, 0};   ///< mm, rest position of window node (0,0,0)
  Vec3d spacing{1, 1, 1};  ///< mm
  TSF_HD_INLINE bool empty() const {
    return displacement == nullptr || dims.x < 2 || dims.y < 2 || dims.z < 2;
  }
};

struct LocalWarp {
  Vec3d rest_centre{0, 0, 0};                     ///< X, mm
  double F[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};      ///< deformation gradient, row-major
  double F_inv[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};  ///< its inverse
  bool in_window = false;  ///< X lies in the captured lattice window (else identity)

  TSF_HD_INLINE Vec3d to_rest(const Vec3d& d) const {  ///< world offset → rest offset
    return {F_inv[0] * d.x + F_inv[1] * d.y + F_inv[2] * d.z,
            F_inv[3] * d.x + F_inv[4] * d.y + F_inv[5] * d.z,
            F_inv[6] * d.x + F_inv[7] * d.y + F_inv[8] * d.z};
  }
  TSF_HD_INLINE Vec3d to_world(const Vec3d& d) const {  ///< rest offset → world offset
    return {F[0] * d.x + F[1] * d.y + F[2] * d.z, F[3] * d.x + F[4] * d.y + F[5] * d.z,
            F[6] * d.x + F[7] * d.y + F[8] * d.z};
  }
};

/// Trilinear displacement at rest point X and its gradient (grad[3a+b] = ∂u_a/∂X_b).
/// Returns false when X lies outside the window's node hull or no corner is alive.
TSF_HD_INLINE bool lattice_displacement(const LatticeWindowView& w, const Vec3d& X, Vec3d& u,
                                        double grad[9]) {
  int cell[3];
  double t[3];
  for (int a = 0; a < 3; ++a) {
    const double s = (X[a] - w.origin[a]) / w.spacing[a];
    const int n = w.dims[a];
    if (!(s >= 0.0) || s > n - 1) return false;
    int c = static_cast<int>(s);
    if (c > n - 2) c = n - 2;
    cell[a] = c;
    t[a] = s - c;
  }
  double weight_sum = 0, dw_sum[3] = {0, 0, 0};
  Vec3d acc{0, 0, 0};
  Vec3d dacc[3] = {{0, 0, 0}, {0, 0, 0}, {0, 0, 0}};
  for (int corner = 0; corner < 8; ++corner) {
    const int o[3] = {corner & 1, (corner >> 1) & 1, (corner >> 2) & 1};
    const long long idx =
        (cell[0] + o[0]) +
        static_cast<long long>(w.dims.x) *
            ((cell[1] + o[1]) + static_cast<long long>(w.dims.y) * (cell[2] + o[2]));
    if (!w.alive[idx]) continue;
    double f[3], df[3];
    for (int a = 0; a < 3; ++a) {
      f[a] = o[a] ? t[a] : 1.0 - t[a];
      df[a] = (o[a] ? 1.0 : -1.0) / w.spacing[a];
    }
    const double wc = f[0] * f[1] * f[2];
    const double dwc[3] = {df[0] * f[1] * f[2], f[0] * df[1] * f[2], f[0] * f[1] * df[2]};
    const Vec3d uc = to_double(w.displacement[idx]);
    weight_sum += wc;
    acc += uc * wc;
    for (int b = 0; b < 3; ++b) {
      dw_sum[b] += dwc[b];
      dacc[b] += uc * dwc[b];
    }
  }
  if (!(weight_sum > 1e-9)) return false;
  u = acc / weight_sum;
  // Gradient of the renormalised interpolation Σw·u / Σw.
  for (int b = 0; b < 3; ++b) {
    const Vec3d g = (dacc[b] - u * dw_sum[b]) / weight_sum;
    grad[0 * 3 + b] = g.x;
    grad[1 * 3 + b] = g.y;
    grad[2 * 3 + b] = g.z;
  }
  return true;
}

/// The local warp at stylus centre p (deformed world, mm).
TSF_HD_INLINE LocalWarp inverse_warp(const LatticeWindowView& w, const Vec3d& p) {
  LocalWarp warp;
  warp.rest_centre = p;
  if (w.empty()) return warp;
  Vec3d X = p, u{0, 0, 0};
  double grad[9];
  bool ok = false;
  for (int it = 0; it < 6; ++it) {
    Vec3d u_it;
    if (!lattice_displacement(w, X, u_it, grad)) break;
    ok = true;
    u = u_it;
    const Vec3d next = p - u;
    const double moved = length(next - X);
    X = next;
    if (moved < 1e-6) break;
  }
  if (!ok || !lattice_displacement(w, X, u, grad)) return warp;
  double F[9];
  for (int i = 0; i < 9; ++i) F[i] = grad[i] + ((i % 4) == 0 ? 1.0 : 0.0);
  const double det = F[0] * (F[4] * F[8] - F[5] * F[7]) - F[1] * (F[3] * F[8] - F[5] * F[6]) +
                     F[2] * (F[3] * F[7] - F[4] * F[6]);
  if (!(det > 1e-3)) return warp;  // an inverted or collapsed cube: keep the identity
  const double inv = 1.0 / det;
  warp.F_inv[0] = (F[4] * F[8] - F[5] * F[7]) * inv;
  warp.F_inv[1] = (F[2] * F[7] - F[1] * F[8]) * inv;
  warp.F_inv[2] = (F[1] * F[5] - F[2] * F[4]) * inv;
  warp.F_inv[3] = (F[5] * F[6] - F[3] * F[8]) * inv;
  warp.F_inv[4] = (F[0] * F[8] - F[2] * F[6]) * inv;
  warp.F_inv[5] = (F[2] * F[3] - F[0] * F[5]) * inv;
  warp.F_inv[6] = (F[3] * F[7] - F[4] * F[6]) * inv;
  warp.F_inv[7] = (F[1] * F[6] - F[0] * F[7]) * inv;
  warp.F_inv[8] = (F[0] * F[4] - F[1] * F[3]) * inv;
  for (int i = 0; i < 9; ++i) warp.F[i] = F[i];
  warp.rest_centre = X;
  warp.in_window = true;
  return warp;
}

}  // namespace tsf::coupler
