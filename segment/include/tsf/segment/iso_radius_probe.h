// Where a density volume's 0.5 iso-surface lies around a centre, measured along rays.
//
// Rays leave `centre_mm` in `ray_count` directions spread evenly on the sphere (Fibonacci
// lattice); along each, density is trilinearly interpolated (the same interpolation an IMT or
// marching-cubes surface uses) and the first crossing of `iso_level` from inside to outside is
// bracketed by steps of 0.05 voxel and refined by bisection to 1e-4 voxel.
#pragma once

#include <vector>

#include "tsf/common/vec3.h"
#include "tsf/segment/segment_image_types.h"

namespace tsf::segment {

struct IsoRadiusStatistics {
  std::vector<double> radii_mm;    ///< per ray; rays that never cross are left out
  double mean_error_mm = 0.0;      ///< mean of (radius − true radius): bias
  double mean_abs_error_mm = 0.0;  ///< mean |radius − true radius|
  double max_abs_error_mm = 0.0;
  int missed_rays = 0;  ///< rays with no crossing inside the image
};

/// `true_radius_mm` is the reference the errors are taken against.
IsoRadiusStatistics probe_iso_radius(const DensityImage* density, const Vec3d& centre_mm,
                                     double true_radius_mm, int ray_count = 500,
                                     float iso_level = 0.5f);

}  // namespace tsf::segment
