// Closed triangle meshes for the collision tests: a sphere (subdivided octahedron) and a box.
#pragma once

#include <array>
#include <cmath>
#include <cstdint>
#include <map>
#include <utility>
#include <vector>

#include "tsf/common/vec3.h"

namespace tsf::collision::test {

struct Mesh {
  std::vector<Vec3f> vertices;
  std::vector<std::array<std::uint32_t, 3>> triangles;
};

/// A sphere of `radius` about `centre`: an octahedron subdivided `levels` times, its vertices on
/// the sphere (outward winding).
inline Mesh sphere_mesh(double radius, int levels, const Vec3d& centre = {0, 0, 0}) {
  std::vector<Vec3d> v = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
  std::vector<std::array<std::uint32_t, 3>> t = {{0, 2, 4}, {2, 1, 4}, {1, 3, 4}, {3, 0, 4},
                                                 {2, 0, 5}, {1, 2, 5}, {3, 1, 5}, {0, 3, 5}};
  for (int l = 0; l < levels; ++l) {
    std::map<std::pair<std::uint32_t, std::uint32_t>, std::uint32_t> mid;
    auto middle = [&](std::uint32_t a, std::uint32_t b) {
      const auto key = std::make_pair(std::min(a, b), std::max(a, b));
      const auto it = mid.find(key);
      if (it != mid.end()) return it->second;
      v.push_back(normalized_or_zero(v[a] + v[b]));
      const auto id = static_cast<std::uint32_t>(v.size() - 1);
      mid[key] = id;
      return id;
    };
    std::vector<std::array<std::uint32_t, 3>> next;
    for (const auto& f : t) {
      const std::uint32_t ab = middle(f[0], f[1]), bc = middle(f[1], f[2]), ca = middle(f[2], f[0]);
      next.push_back({f[0], ab, ca});
      next.push_back({ab, f[1], bc});
      next.push_back({ca, bc, f[2]});
      next.push_back({ab, bc, ca});
    }
    t.swap(next);
  }
  Mesh m;
  for (const Vec3d& p : v) m.vertices.push_back(to_float(centre + p * radius));
  m.triangles = t;
  return m;
}

/// An axis-aligned box [lo, hi] as 12 triangles.
inline Mesh box_mesh(const Vec3d& lo, const Vec3d& hi) {
  Mesh m;
  for (int c = 0; c < 8; ++c)
    m.vertices.push_back(
        to_float(Vec3d{c & 1 ? hi.x : lo.x, c & 2 ? hi.y : lo.y, c & 4 ? hi.z : lo.z}));
  m.triangles = {{0, 2, 1}, {1, 2, 3}, {4, 5, 6}, {5, 7, 6}, {0, 1, 4}, {1, 5, 4},
                 {2, 6, 3}, {3, 6, 7}, {0, 4, 2}, {2, 4, 6}, {1, 3, 5}, {3, 7, 5}};
  return m;
}

}  // namespace tsf::collision::test
