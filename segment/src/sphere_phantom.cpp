#include "tsf/segment/sphere_phantom.h"

#include <cmath>
#include <string>

#include "tsf/common/error.h"

namespace tsf::segment {

HuImage::Pointer make_sphere_phantom(const SpherePhantom& p) {
  require(
      p.dims > 0 && p.dims_z >= 0 && p.spacing_mm > 0.0 && p.radius_mm > 0.0 && p.supersampling > 0,
      "sphere phantom: dims, spacing, radius and supersampling must be positive");
  const double sz = p.spacing_z_mm > 0.0 ? p.spacing_z_mm : p.spacing_mm;
  const double spacing[3] = {p.spacing_mm, p.spacing_mm, sz};
  auto image = HuImage::New();
  const int nz = p.dims_z > 0 ? p.dims_z : p.dims;
  HuImage::SizeType size;
  size[0] = size[1] = static_cast<itk::SizeValueType>(p.dims);
  size[2] = static_cast<itk::SizeValueType>(nz);
  image->SetRegions(HuImage::RegionType(size));
  HuImage::SpacingType s;
  HuImage::PointType origin;
  for (int a = 0; a < 3; ++a) {
    s[a] = spacing[a];
    origin[a] = -0.5 * ((a == 2 ? nz : p.dims) - 1) * spacing[a];
  }
  image->SetSpacing(s);
  image->SetOrigin(origin);
  image->Allocate();

  const int k = p.supersampling;
  const double half_diagonal =
      0.5 * std::sqrt(spacing[0] * spacing[0] + spacing[1] * spacing[1] + spacing[2] * spacing[2]);
  float* out = image->GetBufferPointer();
  std::size_t v = 0;
  for (int z = 0; z < nz; ++z)
    for (int y = 0; y < p.dims; ++y)
      for (int x = 0; x < p.dims; ++x, ++v) {
        const double c[3] = {origin[0] + x * spacing[0], origin[1] + y * spacing[1],
                             origin[2] + z * spacing[2]};
        const double dx = c[0] - p.centre_mm.x, dy = c[1] - p.centre_mm.y,
                     dz = c[2] - p.centre_mm.z;
        const double d = std::sqrt(dx * dx + dy * dy + dz * dz);
        double inside;
        if (d <= p.radius_mm - half_diagonal) {
          inside = 1.0;
        } else if (d >= p.radius_mm + half_diagonal) {
          inside = 0.0;
        } else {
          // The surface crosses this voxel's cube: count sub-sample centres inside.
          int hits = 0;
          for (int i = 0; i < k; ++i)
            for (int j = 0; j < k; ++j)
              for (int l = 0; l < k; ++l) {
                const double ox = ((i + 0.5) / k - 0.5) * spacing[0];
                const double oy = ((j + 0.5) / k - 0.5) * spacing[1];
                const double oz = ((l + 0.5) / k - 0.5) * spacing[2];
                const double ex = dx + ox, ey = dy + oy, ez = dz + oz;
                if (ex * ex + ey * ey + ez * ez <= p.radius_mm * p.radius_mm) ++hits;
              }
          inside = static_cast<double>(hits) / (k * k * k);
        }
        out[v] = static_cast<float>(p.outside_hu + inside * (p.inside_hu - p.outside_hu));
      }
  return image;
}

}  // namespace tsf::segment
