#include "tsf/import/ct_geometry.h"

#include <algorithm>
#include <cmath>

#include "tsf/import/volume_file_reader.h"

namespace tsf::import {

double Box3::distance(const Vec3d& p) const {
  double d2 = 0;
  for (int a = 0; a < 3; ++a) {
    const double d = std::max({lo[a] - p[a], 0.0, p[a] - hi[a]});
    d2 += d * d;
  }
  return std::sqrt(d2);
}

CtGeometry dicom_series_geometry(const DicomSeries& series) {
  CtGeometry g;
  g.kind = "dicom";
  g.series_instance_uid = series.series_instance_uid;
  if (!series.geometry) return g;
  const OrthogonalGrid& grid = series.geometry->grid;
  g.dims = grid.dims;
  g.spacing = grid.spacing;
  g.origin = grid.origin;
  for (int a = 0; a < 3; ++a)
    for (int r = 0; r < 3; ++r) g.direction[r * 3 + a] = grid.axes[a][r];
  g.resampled = series.geometry->needs_resampling;
  return g;
}

CtGeometry volume_file_geometry(const std::filesystem::path& path, std::int64_t max_voxels) {
  const VolumeFileHeader h = inspect_volume_file(path, max_voxels);
  CtGeometry g;
  g.kind = h.format;
  g.dims = h.dims;
  g.spacing = h.spacing;
  g.origin = h.origin;
  g.direction = h.direction;
  g.orientation_recorded = h.has_patient_orientation;
  return g;
}

Box3 patient_extent(const CtGeometry& g) {
  Box3 box{{1e300, 1e300, 1e300}, {-1e300, -1e300, -1e300}};
  for (int corner = 0; corner < 8; ++corner) {
    Vec3d s;
    for (int a = 0; a < 3; ++a)
      s[a] = ((corner >> a) & 1 ? std::max(g.dims[a] - 1, 0) : 0) * g.spacing[a];
    Vec3d p;
    for (int r = 0; r < 3; ++r)
      p[r] = g.origin[r] + g.direction[r * 3 + 0] * s.x + g.direction[r * 3 + 1] * s.y +
             g.direction[r * 3 + 2] * s.z;
    for (int a = 0; a < 3; ++a) {
      box.lo[a] = std::min(box.lo[a], p[a]);
      box.hi[a] = std::max(box.hi[a], p[a]);
    }
  }
  return box;
}

Box3 tissue_extent(const CtGeometry& g) {
  Box3 box{g.origin, g.origin};
  for (int a = 0; a < 3; ++a) box.hi[a] += std::max(g.dims[a] - 1, 0) * g.spacing[a];
  return box;
}

bool identity_direction(const std::array<double, 9>& direction) {
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c)
      if (std::abs(direction[r * 3 + c] - (r == c ? 1.0 : 0.0)) > 1e-6) return false;
  return true;
}

namespace {

/// The patient axis (0 = x, 1 = y, 2 = z) an axis column points along most.
int dominant_row(const std::array<double, 9>& d, int column) {
  int best = 0;
  for (int r = 1; r < 3; ++r)
    if (std::abs(d[r * 3 + column]) > std::abs(d[best * 3 + column])) best = r;
  return best;
}

}  // namespace

std::string orientation_code(const std::array<double, 9>& direction) {
  static const char kToward[3][2] = {{'L', 'R'}, {'P', 'A'}, {'S', 'I'}};
  std::string code;
  for (int c = 0; c < 3; ++c) {
    const int r = dominant_row(direction, c);
    code += kToward[r][direction[r * 3 + c] >= 0 ? 0 : 1];
  }
  return code;
}

double obliquity_deg(const std::array<double, 9>& direction) {
  double worst = 0;
  for (int c = 0; c < 3; ++c) {
    const int r = dominant_row(direction, c);
    double norm2 = 0;
    for (int k = 0; k < 3; ++k) norm2 += direction[k * 3 + c] * direction[k * 3 + c];
    const double cosine = std::abs(direction[r * 3 + c]) / std::sqrt(std::max(norm2, 1e-300));
    worst = std::max(worst, std::acos(std::min(1.0, cosine)) * 180.0 / M_PI);
  }
  return worst;
}

}  // namespace tsf::import
