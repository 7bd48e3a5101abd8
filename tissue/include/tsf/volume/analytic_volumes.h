// Volumes with analytic surfaces, for tests, benchmarks and demos: the exact surface is known, so
// a surfacing's error can be measured.
//
// Density is a clamped signed-distance ramp: density = clamp(0.5 − d / (2·ramp), 0, 1) for the
// signed distance d (mm, negative inside), so the 0.5 iso-level is the analytic surface and the
// density is linear across ±ramp mm of it (what linear interpolation reproduces best).
#pragma once

#include <cstdint>
#include <functional>

#include "tsf/common/vec3.h"
#include "tsf/volume/tissue_labels.h"
#include "tsf/volume/voxel_volume.h"

namespace tsf {

struct SphereField {
  Vec3d centre;   ///< mm
  double radius;  ///< mm
  double signed_distance(const Vec3d& p) const { return length(p - centre) - radius; }
};

/// A torus around the z axis through `centre`: tube of radius `minor` around a circle of `major`.
struct TorusField {
  Vec3d centre;
  double major, minor;  ///< mm
  double signed_distance(const Vec3d& p) const {
    const Vec3d q = p - centre;
    const double ring = std::sqrt(q.x * q.x + q.y * q.y) - major;
    return std::sqrt(ring * ring + q.z * q.z) - minor;
  }
};

/// clamp(0.5 − d / (2·ramp_mm), 0, 1); a hard step when ramp_mm <= 0.
float ramp_density(double signed_distance_mm, double ramp_mm);

/// Fills density from a signed-distance function of tissue-space position (mm), label `label`
/// where density >= 0.5, kLabelOutside elsewhere; brick ranges current. OpenMP over slices.
VoxelVolume make_sdf_volume(const VolumeGeometry& geometry,
                            const std::function<double(const Vec3d&)>& signed_distance,
                            double ramp_mm, std::uint8_t label = kLabelSoftTissue);

/// Geometry of an n_x × n_y × n_z volume with isotropic `spacing` mm and origin 0.
VolumeGeometry cube_geometry(const Int3& dims, double spacing = 1.0);

/// "Organ-like" test data: a smooth union of `count` random ellipsoidal blobs (seeded), with a
/// few spherical cavities, filling most of the volume; density ramps over ±ramp_mm. Labels
/// alternate between soft tissue, mucosa and cartilage per blob.
VoxelVolume make_blob_volume(const VolumeGeometry& geometry, unsigned seed, int count = 12,
                             double ramp_mm = 1.5);

}  // namespace tsf
