// Exact squared Euclidean distance transform of a binary mask on an anisotropic grid.
//
// Felzenszwalb & Huttenlocher (2012), "Distance Transforms of Sampled Functions": the squared
// distance separates into 1-D passes, one per axis; each pass takes the lower envelope of the
// parabolas f(q) + s²(p − q)² in O(n). Cost is linear in the voxel count and independent of the
// distances involved, so morphology by a ball of any radius costs the same. Passes run in
// parallel over lines (ITK's thread pool).
#pragma once

#include <array>
#include <cstddef>
#include <functional>

namespace tsf::segment {

/// For every voxel, the squared distance in mm² to the nearest voxel whose `mask` value is
/// non-zero (0 on such voxels); +infinity when the mask is empty.
///   mask, squared_mm2  dims[0]·dims[1]·dims[2] values, x fastest
///   spacing_mm         voxel spacing per axis, mm
/// `progress` (optional) receives fractions in [0,1] as the passes complete.
void squared_distance_to_foreground(const unsigned char* mask,
                                    const std::array<std::size_t, 3>& dims,
                                    const std::array<double, 3>& spacing_mm, float* squared_mm2,
                                    const std::function<void(double)>& progress = {});

}  // namespace tsf::segment
