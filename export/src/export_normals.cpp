#include "tsf/export/export_normals.h"

#include <algorithm>
#include <cmath>

#include "tsf/common/error.h"

namespace tsf::exporter {

namespace {
using Tri = std::array<std::uint32_t, 3>;
}  // namespace

std::vector<Vec3f> area_weighted_normals(const std::vector<Vec3f>& positions,
                                         const std::vector<Tri>& triangles,
                                         const std::vector<std::uint32_t>& group,
                                         std::size_t* without_area) {
  const std::size_t nv = positions.size();
  require(group.empty() || group.size() == nv, "area_weighted_normals: a group per vertex");
  std::size_t groups = nv;
  if (!group.empty())
    groups = static_cast<std::size_t>(*std::max_element(group.begin(), group.end())) + 1;
  const auto g = [&](std::uint32_t v) { return group.empty() ? v : group[v]; };
  std::vector<Vec3d> sum(groups, Vec3d{0, 0, 0});
  for (const Tri& t : triangles) {
    const Vec3d a = to_double(positions[t[0]]);
    const Vec3d n = cross(to_double(positions[t[1]]) - a, to_double(positions[t[2]]) - a);
    for (std::uint32_t v : t) sum[g(v)] += n;
  }
  std::vector<Vec3f> normals(nv, Vec3f{0, 0, 0});
  std::vector<std::uint32_t> bad;
  for (std::uint32_t v = 0; v < nv; ++v) {
    const Vec3d& s = sum[g(v)];
    const double l = length(s);
    if (l > 0.0 && std::isfinite(l))
      normals[v] = to_float(s / l);
    else
      bad.push_back(v);
  }
  if (without_area) *without_area = bad.size();
  if (bad.empty()) return normals;
  // No area around it: the mean of the neighbours' normals.
  std::vector<char> is_bad(nv, 0);
  for (std::uint32_t v : bad) is_bad[v] = 1;
  std::vector<Vec3d> from_neighbours(nv, Vec3d{0, 0, 0});
  for (const Tri& t : triangles)
    for (int k = 0; k < 3; ++k)
      if (is_bad[t[k]])
        for (int j = 1; j < 3; ++j)
          if (!is_bad[t[(k + j) % 3]]) from_neighbours[t[k]] += to_double(normals[t[(k + j) % 3]]);
  for (std::uint32_t v : bad) {
    const double l = length(from_neighbours[v]);
    normals[v] = l > 1e-12 ? to_float(from_neighbours[v] / l) : Vec3f{0, 0, 1};
  }
  return normals;
}

}  // namespace tsf::exporter
