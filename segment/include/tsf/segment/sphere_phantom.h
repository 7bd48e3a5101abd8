// An analytic phantom for accuracy tests and benchmarks: a sphere of known radius in HU, sampled
// with partial volume (each voxel holds the fraction of its cube inside the sphere, mixed between
// the two HU plateaus) as a CT scanner's detector integration would.
#pragma once

#include "tsf/common/vec3.h"
#include "tsf/segment/segment_image_types.h"

namespace tsf::segment {

struct SpherePhantom {
  int dims = 48;              ///< voxels along i and j (and k unless dims_z > 0)
  int dims_z = 0;             ///< voxels along k; 0 = dims
  double spacing_mm = 1.0;    ///< isotropic unless `spacing_z_mm` > 0
  double spacing_z_mm = 0.0;  ///< slice spacing along k; 0 = spacing_mm
  Vec3d centre_mm{0, 0, 0};   ///< physical; the grid is centred on the origin
  double radius_mm = 15.0;
  double inside_hu = 40.0;      ///< soft tissue
  double outside_hu = -1000.0;  ///< air
  int supersampling = 8;        ///< sub-samples per axis for voxels the surface crosses
};

/// The phantom image: identity direction, centred on the origin (voxel (0,0,0) at
/// −(dims−1)/2·spacing per axis).
HuImage::Pointer make_sphere_phantom(const SpherePhantom& phantom);

}  // namespace tsf::segment
