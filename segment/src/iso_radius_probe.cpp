#include "tsf/segment/iso_radius_probe.h"

#include <itkLinearInterpolateImageFunction.h>

#include <algorithm>
#include <cmath>
#include <limits>

namespace tsf::segment {

IsoRadiusStatistics probe_iso_radius(const DensityImage* density, const Vec3d& centre_mm,
                                     double true_radius_mm, int ray_count, float iso_level) {
  auto interpolate = itk::LinearInterpolateImageFunction<DensityImage, double>::New();
  interpolate->SetInputImage(density);
  const auto& sp = density->GetSpacing();
  const double voxel = std::min({sp[0], sp[1], sp[2]});
  const double step = 0.05 * voxel;
  const double golden = M_PI * (3.0 - std::sqrt(5.0));

  // Density minus the iso-level at distance t along direction u; NaN outside the image.
  auto sample = [&](const double u[3], double t) {
    DensityImage::PointType p;
    p[0] = centre_mm.x + t * u[0];
    p[1] = centre_mm.y + t * u[1];
    p[2] = centre_mm.z + t * u[2];
    if (!interpolate->IsInsideBuffer(p)) return std::numeric_limits<double>::quiet_NaN();
    return interpolate->Evaluate(p) - static_cast<double>(iso_level);
  };

  IsoRadiusStatistics stats;
  for (int r = 0; r < ray_count; ++r) {
    const double z = 1.0 - 2.0 * (r + 0.5) / ray_count;
    const double rho = std::sqrt(std::max(0.0, 1.0 - z * z));
    const double u[3] = {rho * std::cos(golden * r), rho * std::sin(golden * r), z};
    bool found = false;
    if (sample(u, 0.0) >= 0.0) {  // the centre must be inside
      double previous = 0.0;
      for (double t = step;; t += step) {
        const double f = sample(u, t);
        if (std::isnan(f)) break;  // left the image without crossing
        if (f < 0.0) {
          double lo = previous, hi = t;  // sample(lo) >= 0 > sample(hi)
          while (hi - lo > 1e-4 * voxel) {
            const double mid = 0.5 * (lo + hi);
            (sample(u, mid) >= 0.0 ? lo : hi) = mid;
          }
          stats.radii_mm.push_back(0.5 * (lo + hi));
          found = true;
          break;
        }
        previous = t;
      }
    }
    if (!found) ++stats.missed_rays;
  }
  if (!stats.radii_mm.empty()) {
    for (double radius : stats.radii_mm) {
      const double e = radius - true_radius_mm;
      stats.mean_error_mm += e;
      stats.mean_abs_error_mm += std::abs(e);
      stats.max_abs_error_mm = std::max(stats.max_abs_error_mm, std::abs(e));
    }
    stats.mean_error_mm /= static_cast<double>(stats.radii_mm.size());
    stats.mean_abs_error_mm /= static_cast<double>(stats.radii_mm.size());
  }
  return stats;
}

}  // namespace tsf::segment
