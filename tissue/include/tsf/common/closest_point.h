// The closest point of a triangle to a point (Ericson, Real-Time Collision Detection §5.1.5):
// per-point math, TSF_HD, shared by the haptic mesh model (haptics/mesh_force.h) and the
// signed-distance grids of mesh tools (collision/distance_grid.h).
#pragma once

#include <cmath>

#include "tsf/common/hd.h"
#include "tsf/common/vec3.h"

namespace tsf {

/// Closest point of triangle abc to p (Ericson, Real-Time Collision Detection §5.1.5), with its
/// barycentric weights (wa, wb, wc).
TSF_HD_INLINE Vec3d closest_point_on_triangle(const Vec3d& p, const Vec3d& a, const Vec3d& b,
                                              const Vec3d& c, double& wa, double& wb, double& wc) {
  const Vec3d ab = b - a, ac = c - a, ap = p - a;
  const double d1 = dot(ab, ap), d2 = dot(ac, ap);
  if (d1 <= 0 && d2 <= 0) {
    wa = 1;
    wb = 0;
    wc = 0;
    return a;
  }
  const Vec3d bp = p - b;
  const double d3 = dot(ab, bp), d4 = dot(ac, bp);
  if (d3 >= 0 && d4 <= d3) {
    wa = 0;
    wb = 1;
    wc = 0;
    return b;
  }
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) {
    const double v = d1 / (d1 - d3);
    wa = 1 - v;
    wb = v;
    wc = 0;
    return a + ab * v;
  }
  const Vec3d cp = p - c;
  const double d5 = dot(ab, cp), d6 = dot(ac, cp);
  if (d6 >= 0 && d5 <= d6) {
    wa = 0;
    wb = 0;
    wc = 1;
    return c;
  }
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) {
    const double w = d2 / (d2 - d6);
    wa = 1 - w;
    wb = 0;
    wc = w;
    return a + ac * w;
  }
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0) {
    const double w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
    wa = 0;
    wb = 1 - w;
    wc = w;
    return b + (c - b) * w;
  }
  const double area = va + vb + vc;
  if (!(area > 1e-30)) {  // degenerate (collinear corners): the nearest point of its edges
    double u;
    const double lab = dot(ab, ab), lac = dot(ac, ac);
    const Vec3d bc = c - b;
    const double lbc = dot(bc, bc);
    if (lab >= lac && lab >= lbc) {
      u = lab > 0 ? fmin(1.0, fmax(0.0, d1 / lab)) : 0.0;
      wa = 1 - u;
      wb = u;
      wc = 0;
      return a + ab * u;
    }
    if (lac >= lbc) {
      u = lac > 0 ? fmin(1.0, fmax(0.0, d2 / lac)) : 0.0;
      wa = 1 - u;
      wb = 0;
      wc = u;
      return a + ac * u;
    }
    u = fmin(1.0, fmax(0.0, dot(bp, bc) / lbc));
    wa = 0;
    wb = 1 - u;
    wc = u;
    return b + bc * u;
  }
  const double denom = 1.0 / area;
  const double v = vb * denom, w = vc * denom;
  wa = 1 - v - w;
  wb = v;
  wc = w;
  return a + ab * v + ac * w;
}

}  // namespace tsf
