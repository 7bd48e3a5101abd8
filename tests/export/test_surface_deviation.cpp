// Distances to a surface: exact for points near a square, equal to brute force over random
// points, zero between a surface and itself, the shift between two shifted spheres.
#include <gtest/gtest.h>

#include <random>

#include "export_test_helpers.h"
#include "tsf/export/surface_deviation.h"

namespace tsf::exporter {
namespace {
using namespace test;

double brute_force(const imt::SurfaceMesh& m, const Vec3f& q) {
  // Dense sampling is not exact; use the analytic closest point per triangle via projection.
  double best = 1e30;
  for (const auto& t : m.triangles) {
    const Vec3d a = to_double(m.positions[t[0]]), b = to_double(m.positions[t[1]]),
                c = to_double(m.positions[t[2]]), p = to_double(q);
    // Barycentric grid refinement: good to ~1e-4 of the triangle size.
    const int n = 200;
    for (int i = 0; i <= n; ++i)
      for (int j = 0; j <= n - i; ++j) {
        const double u = static_cast<double>(i) / n, v = static_cast<double>(j) / n;
        best = std::min(best, length(a + (b - a) * u + (c - a) * v - p));
      }
  }
  return best;
}

TEST(SurfaceDeviation, DistancesToASquareAreExact) {
  std::vector<Vec3f> p = {{0, 0, 0}, {2, 0, 0}, {2, 2, 0}, {0, 2, 0}};
  std::vector<std::array<std::uint32_t, 3>> t = {{0, 1, 2}, {0, 2, 3}};
  const std::vector<double> d =
      distances_to_surface({&p, &t}, {{1, 1, 0.5f}, {3, 1, 0}, {3, 3, 1}, {0.5f, 1.5f, -2}});
  EXPECT_NEAR(d[0], 0.5, 1e-6);
  EXPECT_NEAR(d[1], 1.0, 1e-6);
  EXPECT_NEAR(d[2], std::sqrt(3.0), 1e-6);
  EXPECT_NEAR(d[3], 2.0, 1e-6);
}

TEST(SurfaceDeviation, MatchesBruteForce) {
  const imt::SurfaceMesh m = labelled_sphere(cube_geometry({10, 10, 10}, 1.0), 3.0);
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> u(-2.0f, 12.0f);
  std::vector<Vec3f> q;
  for (int i = 0; i < 12; ++i) q.push_back({u(rng), u(rng), u(rng)});
  const std::vector<double> d = distances_to_surface({&m.positions, &m.triangles}, q);
  for (std::size_t i = 0; i < q.size(); ++i) EXPECT_NEAR(d[i], brute_force(m, q[i]), 2e-3) << i;
}

TEST(SurfaceDeviation, SelfIsZeroAndAShiftIsMeasured) {
  const VolumeGeometry g = cube_geometry({32, 32, 32}, 0.5);
  const imt::SurfaceMesh a = labelled_sphere(g, 5.0);
  const SurfaceDeviation self =
      measure_deviation({&a.positions, &a.triangles}, {&a.positions, &a.triangles});
  EXPECT_LT(self.max_mm(), 1e-5);
  imt::SurfaceMesh b = a;
  for (Vec3f& p : b.positions) p += Vec3f{0.3f, 0.0f, 0.0f};
  const SurfaceDeviation shift =
      measure_deviation({&a.positions, &a.triangles}, {&b.positions, &b.triangles});
  EXPECT_NEAR(shift.max_mm(), 0.3, 0.02);
  EXPECT_GT(shift.mean_mm(), 0.1);
  EXPECT_LT(shift.mean_mm(), 0.3);
  EXPECT_EQ(shift.from_full_samples, a.vertex_count());
  EXPECT_EQ(shift.to_full_samples, 7 * b.triangle_count());
}

}  // namespace
}  // namespace tsf::exporter
