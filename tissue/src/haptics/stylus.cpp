#include "tsf/haptics/stylus.h"

#include <cmath>
#include <string>

#include "tsf/common/error.h"

namespace tsf::haptics {

double sphere_volume(double radius_mm) {
  return 4.0 / 3.0 * 3.14159265358979323846 * radius_mm * radius_mm * radius_mm;
}

SphereStylus make_sphere_stylus(double radius_mm, int resolution) {
  require(std::isfinite(radius_mm) && radius_mm > 0,
          "stylus radius: expected a finite number > 0 mm, got " + std::to_string(radius_mm));
  require(resolution >= 1 && resolution <= 128,
          "stylus resolution: expected 1..128 cells across, got " + std::to_string(resolution));
  SphereStylus s;
  s.radius_mm = radius_mm;
  s.resolution = resolution;
  s.cell_mm = 2.0 * radius_mm / resolution;
  s.cell_volume_mm3 = s.cell_mm * s.cell_mm * s.cell_mm;
  s.sphere_radius_mm = 0.5 * std::sqrt(3.0) * s.cell_mm;
  const double r2 = radius_mm * radius_mm;
  for (int k = 0; k < resolution; ++k)
    for (int j = 0; j < resolution; ++j)
      for (int i = 0; i < resolution; ++i) {
        const Vec3d c{-radius_mm + (i + 0.5) * s.cell_mm, -radius_mm + (j + 0.5) * s.cell_mm,
                      -radius_mm + (k + 0.5) * s.cell_mm};
        if (length_squared(c) <= r2) s.offsets.push_back(to_float(c));
      }
  if (s.offsets.empty()) s.offsets.push_back({0, 0, 0});  // resolution 1: the centre cell
  s.volume_mm3 = static_cast<double>(s.offsets.size()) * s.cell_volume_mm3;
  return s;
}

SphereStylus make_sphere_set(double radius_mm, int resolution) {
  SphereStylus s = make_sphere_stylus(radius_mm, resolution);  // validates
  if (resolution == 1) {
    s.sphere_radius_mm = radius_mm;
    s.offsets.assign(1, Vec3f{0, 0, 0});
    s.volume_mm3 = sphere_volume(radius_mm);
    return s;
  }
  const double cell = 2.0 * radius_mm / (resolution + std::sqrt(3.0));
  s.cell_mm = cell;
  s.cell_volume_mm3 = cell * cell * cell;
  s.sphere_radius_mm = 0.5 * std::sqrt(3.0) * cell;
  const double inner = radius_mm - s.sphere_radius_mm;
  s.offsets.clear();
  for (int k = 0; k < resolution; ++k)
    for (int j = 0; j < resolution; ++j)
      for (int i = 0; i < resolution; ++i) {
        const Vec3d c{(i + 0.5 - 0.5 * resolution) * cell, (j + 0.5 - 0.5 * resolution) * cell,
                      (k + 0.5 - 0.5 * resolution) * cell};
        if (length(c) <= inner + 1e-12) s.offsets.push_back(to_float(c));
      }
  if (s.offsets.empty()) s.offsets.push_back({0, 0, 0});
  s.volume_mm3 = sphere_volume(radius_mm);
  return s;
}

}  // namespace tsf::haptics
