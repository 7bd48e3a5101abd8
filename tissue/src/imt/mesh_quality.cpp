#include "tsf/imt/mesh_quality.h"

#include <algorithm>
#include <cmath>

namespace tsf::imt {

MeshQuality measure_quality(const SurfaceMesh& mesh, double sliver_angle_deg) {
  MeshQuality q;
  q.triangles = mesh.triangles.size();
  q.min_angle_deg = 180.0;
  double edge_sum = 0, min_sum = 0;
  std::size_t counted = 0;
  for (const auto& t : mesh.triangles) {
    const Vec3d p[3] = {to_double(mesh.positions[t[0]]), to_double(mesh.positions[t[1]]),
                        to_double(mesh.positions[t[2]])};
    const double area2 = length(cross(p[1] - p[0], p[2] - p[0]));
    double longest = 0;
    for (int k = 0; k < 3; ++k) {
      const double e = length(p[(k + 1) % 3] - p[k]);
      edge_sum += e;
      longest = std::max(longest, e);
    }
    q.area += 0.5 * area2;
    if (area2 <= 1e-12 * longest * longest || longest == 0) {
      ++q.zero_area;
      continue;
    }
    double smallest = 180.0;
    for (int k = 0; k < 3; ++k) {
      const Vec3d u = p[(k + 1) % 3] - p[k], v = p[(k + 2) % 3] - p[k];
      const double c = std::clamp(dot(u, v) / (length(u) * length(v)), -1.0, 1.0);
      smallest = std::min(smallest, std::acos(c) * 180.0 / M_PI);
    }
    q.min_angle_deg = std::min(q.min_angle_deg, smallest);
    min_sum += smallest;
    ++counted;
    if (smallest < sliver_angle_deg) ++q.slivers;
  }
  if (counted)
    q.mean_min_angle_deg = min_sum / static_cast<double>(counted);
  else
    q.min_angle_deg = 0;
  if (q.triangles) q.mean_edge_length = edge_sum / (3.0 * static_cast<double>(q.triangles));
  return q;
}

}  // namespace tsf::imt
