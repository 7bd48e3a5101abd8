// Resampling a stack of parallel image planes onto an orthogonal voxel grid.
//
// Each output voxel centre q is located between the two acquired planes that bracket it along
// the plane normal (t = q·normal); on each plane it is sampled bilinearly at its own in-plane
// coordinates (u, v) = ((q − p_m)·row / spacing_x, (q − p_m)·column / spacing_y), and the two
// samples are blended linearly in t. This is trilinear interpolation on the acquired, possibly
// sheared (gantry tilt) and unevenly spaced lattice, so a field that is linear in space is
// reproduced exactly. Samples that fall outside an acquired plane do not contribute; a voxel
// whose inside samples carry less than half of the weight gets `fill_value`.
#pragma once

#include <cstdint>

#include "tsf/common/progress.h"
#include "tsf/common/vec3.h"
#include "tsf/import/slice_stack_geometry.h"

namespace tsf::import {

/// Acquired planes, sorted by offset along the normal (strictly increasing).
struct SliceStackSamples {
  /// columns×rows×slices values, row-major per slice: value(i, j, m) at [(m·rows + j)·columns + i]
  const float* values = nullptr;
  int columns = 0, rows = 0, slices = 0;
  const Vec3d* positions = nullptr;  ///< ImagePositionPatient of each slice, #slices, mm
  Vec3d row{1, 0, 0};                ///< unit, LPS
  Vec3d column{0, 1, 0};             ///< unit, LPS
  double spacing_x = 1;              ///< mm between columns
  double spacing_y = 1;              ///< mm between rows
};

struct ResampleOptions {
  float fill_value = 0;  ///< value of voxels outside the acquired planes
  /// Round results to whole numbers (halves to even). Only for inputs within ±2^22 (4194304),
  /// where float rounding by the 1.5·2^23 trick is exact.
  bool round_to_integer = false;
};

struct ResampleStatistics {
  std::int64_t filled_voxels = 0;  ///< voxels outside the acquired planes (got fill_value)
  float min = 0, max = 0;          ///< of the output values (fill included)
  /// Every output value is a whole number (always so with round_to_integer; otherwise only
  /// exact for inputs within ±2^22).
  bool integral = false;
};

/// Writes grid.dims.x×y×z values (x fastest) to `out`. Parallel over output slices (OpenMP);
/// `progress` (optional) advances by one per output slice.
ResampleStatistics resample_slice_stack(const SliceStackSamples& in, const OrthogonalGrid& grid,
                                        const ResampleOptions& options, float* out,
                                        Progress* progress = nullptr);

}  // namespace tsf::import
