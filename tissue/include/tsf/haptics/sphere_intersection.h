// The analytic reference for the voxel model: the volume shared by two spheres.
//
// Spheres of radii r and R with centres d apart overlap in a lens of volume
//   V = π (R + r − d)² (d² + 2dr − 3r² + 2dR + 6rR − 3R²) / (12 d),   |R − r| < d < R + r
// (two spherical caps); 0 for d ≥ R + r; the smaller sphere's volume for d ≤ |R − r|.
#pragma once

#include <cmath>

#include "tsf/common/hd.h"

namespace tsf::haptics {

/// Lens volume of spheres of radii r, R at centre distance d (all mm), mm³.
TSF_HD_INLINE double sphere_intersection_volume(double r, double R, double d) {
  const double pi = 3.14159265358979323846;
  if (d >= r + R) return 0.0;
  if (d <= fabs(R - r)) {
    const double m = r < R ? r : R;
    return 4.0 / 3.0 * pi * m * m * m;
  }
  const double s = R + r - d;
  return pi * s * s * (d * d + 2 * d * r - 3 * r * r + 2 * d * R + 6 * r * R - 3 * R * R) /
         (12.0 * d);
}

}  // namespace tsf::haptics
