// How far a simplified surface lies from the full one, in mm (the error `tsf export --decimate`
// reports).
//
// Two directions, each over sample points, each distance the exact distance from the point to
// the nearest point of the other surface's triangles (a bounding-volume hierarchy of triangles,
// closest point on a triangle as in Ericson, Real-Time Collision Detection §5.1.5):
//   to_full    points on the simplified surface: each triangle's centroid, edge midpoints and the
//              three points (2/3, 1/6, 1/6) in barycentric coordinates (its corners are full
//              surface vertices, distance 0); mean weighted by the area each point stands for
//   from_full  every vertex of the full surface; plain mean
// The two-sided figures: max = the larger maximum (a sampled Hausdorff distance), mean = the mean
// of the two means. The queries run on all OpenMP threads.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "tsf/common/vec3.h"

namespace tsf::exporter {

struct SurfaceDeviation {
  double to_full_mean_mm = 0, to_full_max_mm = 0;
  double from_full_mean_mm = 0, from_full_max_mm = 0;
  std::size_t to_full_samples = 0, from_full_samples = 0;
  double seconds = 0;

  double max_mm() const {
    return to_full_max_mm > from_full_max_mm ? to_full_max_mm : from_full_max_mm;
  }
  double mean_mm() const { return 0.5 * (to_full_mean_mm + from_full_mean_mm); }
};

/// A triangle soup for distance queries (positions, mm).
struct TriangleSet {
  const std::vector<Vec3f>* positions = nullptr;
  const std::vector<std::array<std::uint32_t, 3>>* triangles = nullptr;
};

/// Deviation of `simplified` from `full` (same frame). Throws tsf::Error when either is empty.
SurfaceDeviation measure_deviation(const TriangleSet& full, const TriangleSet& simplified);

/// Distance from each point to the nearest triangle of `surface` (for tests and tools).
std::vector<double> distances_to_surface(const TriangleSet& surface,
                                         const std::vector<Vec3f>& points);

}  // namespace tsf::exporter
