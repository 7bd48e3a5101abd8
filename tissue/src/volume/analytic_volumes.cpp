#include "tsf/volume/analytic_volumes.h"

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

namespace tsf {

float ramp_density(double d, double ramp_mm) {
  if (ramp_mm <= 0.0) return d <= 0.0 ? 1.0f : 0.0f;
  const double v = 0.5 - d / (2.0 * ramp_mm);
  return static_cast<float>(std::clamp(v, 0.0, 1.0));
}

VolumeGeometry cube_geometry(const Int3& dims, double spacing) {
  VolumeGeometry g;
  g.dims = dims;
  g.spacing = {spacing, spacing, spacing};
  return g;
}

VoxelVolume make_sdf_volume(const VolumeGeometry& geometry,
                            const std::function<double(const Vec3d&)>& signed_distance,
                            double ramp_mm, std::uint8_t label) {
  VoxelVolume volume(geometry);
  float* d = volume.density_for_tracked_write();
  std::uint8_t* l = volume.labels_for_tracked_write();
  const Int3 n = geometry.dims;
#pragma omp parallel for schedule(dynamic, 1) if (geometry.voxel_count() >= (1u << 18))
  for (int k = 0; k < n.z; ++k)
    for (int j = 0; j < n.y; ++j)
      for (int i = 0; i < n.x; ++i) {
        const std::size_t v = volume.index(i, j, k);
        d[v] = ramp_density(
            signed_distance(geometry.index_to_tissue({double(i), double(j), double(k)})), ramp_mm);
        l[v] = d[v] >= 0.5f ? label : static_cast<std::uint8_t>(kLabelOutside);
      }
  volume.mark_all_modified();
  return volume;
}

VoxelVolume make_blob_volume(const VolumeGeometry& geometry, unsigned seed, int count,
                             double ramp_mm) {
  struct Blob {
    Vec3d centre, inv_radii;
    std::uint8_t label;
  };
  std::mt19937 rng(seed);
  const Vec3d ext{geometry.dims.x * geometry.spacing.x, geometry.dims.y * geometry.spacing.y,
                  geometry.dims.z * geometry.spacing.z};
  const double scale = std::min(ext.x, std::min(ext.y, ext.z));
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  const std::uint8_t labels[3] = {kLabelSoftTissue, kLabelMucosa, kLabelCartilage};
  std::vector<Blob> blobs, cavities;
  for (int b = 0; b < count; ++b) {
    const Vec3d c{geometry.origin.x + ext.x * (0.2 + 0.6 * unit(rng)),
                  geometry.origin.y + ext.y * (0.2 + 0.6 * unit(rng)),
                  geometry.origin.z + ext.z * (0.2 + 0.6 * unit(rng))};
    const Vec3d r{scale * (0.10 + 0.12 * unit(rng)), scale * (0.10 + 0.12 * unit(rng)),
                  scale * (0.10 + 0.12 * unit(rng))};
    blobs.push_back({c, {1.0 / r.x, 1.0 / r.y, 1.0 / r.z}, labels[b % 3]});
  }
  for (int b = 0; b < count / 3; ++b) {
    const Blob& host = blobs[static_cast<std::size_t>(b)];
    const double r = scale * (0.03 + 0.04 * unit(rng));
    cavities.push_back({host.centre, {1.0 / r, 1.0 / r, 1.0 / r}, 0});
  }
  // Approximate signed distance of an ellipsoid (scaled by its smallest radius), smooth union.
  auto ellipsoid = [](const Blob& b, const Vec3d& p) {
    const Vec3d q = cwise_mul(p - b.centre, b.inv_radii);
    const double rmin = 1.0 / std::max(b.inv_radii.x, std::max(b.inv_radii.y, b.inv_radii.z));
    return (length(q) - 1.0) * rmin;
  };
  const double k = 0.04 * scale;  // smooth-union width
  VoxelVolume volume(geometry);
  float* d = volume.density_for_tracked_write();
  std::uint8_t* l = volume.labels_for_tracked_write();
  const Int3 n = geometry.dims;
#pragma omp parallel for schedule(dynamic, 1) if (geometry.voxel_count() >= (1u << 18))
  for (int z = 0; z < n.z; ++z)
    for (int y = 0; y < n.y; ++y)
      for (int x = 0; x < n.x; ++x) {
        const Vec3d p = geometry.index_to_tissue({double(x), double(y), double(z)});
        double sd = 1e30;
        std::uint8_t label = kLabelSoftTissue;
        double best = 1e30;
        for (const Blob& b : blobs) {
          const double e = ellipsoid(b, p);
          if (e < best) {
            best = e;
            label = b.label;
          }
          const double h = std::clamp(0.5 + 0.5 * (e - sd) / k, 0.0, 1.0);
          sd = e * (1.0 - h) + sd * h - k * h * (1.0 - h);
        }
        for (const Blob& c : cavities) sd = std::max(sd, -ellipsoid(c, p));
        const std::size_t v = volume.index(x, y, z);
        d[v] = ramp_density(sd, ramp_mm);
        l[v] = d[v] >= 0.5f ? label : static_cast<std::uint8_t>(kLabelOutside);
      }
  volume.mark_all_modified();
  return volume;
}

}  // namespace tsf
