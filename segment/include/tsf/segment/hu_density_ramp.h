// Density as a smooth function of HU around the tissue boundary.
//
// For a boundary at threshold t with ramp width w (HU), the rising ramp is
//   d(h) = clamp(0.5 + (h − t)/w, 0, 1)          (tissue above t; the falling ramp mirrors it)
// so d = 0.5 exactly where h = t. Linear interpolation of d between two voxels therefore puts the
// 0.5 crossing where linear interpolation of h crosses t: the iso-surface follows the HU
// threshold with sub-voxel accuracy as long as neither voxel is clamped (w wider than the HU step
// across the boundary; the accuracy benchmark in bench/segment measures what w and smoothing
// cost). For a step between plateaus a and b sampled with partial volume, t = (a + b)/2 puts the
// surface on the true edge. w = 0 gives a hard step (density 0 or 1; a binary mask).
// A band (tissue between two thresholds) is the minimum of a rising and a falling ramp.
#pragma once

#include <algorithm>

namespace tsf::segment {

/// Rising ramp: 0 well below `threshold_hu`, 1 well above, 0.5 at it.
inline float rising_density_ramp(float hu, float threshold_hu, float ramp_hu) {
  if (ramp_hu <= 0.0f) return hu >= threshold_hu ? 1.0f : 0.0f;
  return std::clamp(0.5f + (hu - threshold_hu) / ramp_hu, 0.0f, 1.0f);
}

/// Falling ramp: 1 well below `threshold_hu`, 0 well above, 0.5 at it.
inline float falling_density_ramp(float hu, float threshold_hu, float ramp_hu) {
  if (ramp_hu <= 0.0f) return hu < threshold_hu ? 1.0f : 0.0f;
  return std::clamp(0.5f - (hu - threshold_hu) / ramp_hu, 0.0f, 1.0f);
}

}  // namespace tsf::segment
