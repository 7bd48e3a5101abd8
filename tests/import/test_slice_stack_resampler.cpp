// Resampling of sheared and unevenly spaced stacks: trilinear interpolation on the acquired
// lattice reproduces any field that is linear in space, so the resampled values must equal the
// field at every output voxel inside the stack.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "tsf/import/slice_stack_geometry.h"
#include "tsf/import/slice_stack_resampler.h"

namespace tsf::import {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr float kFill = -9999.0f;

double linear_field(const Vec3d& p) {
  return 3.0 * p.x - 2.0 * p.y + 5.0 * p.z + 100.0;
}

struct Case {
  std::vector<Vec3d> positions;
  Vec3d row, column;
  double px = 1.0;
  int cols = 40, rows = 30;
};

/// Samples `linear_field` on the stack, resamples it, and checks every inside voxel.
void check_linear_field_is_reproduced(const Case& c, bool expect_fill) {
  const auto g = analyze_slice_stack(c.positions, {c.row, c.column}, c.px, c.px, c.cols, c.rows);
  ASSERT_TRUE(g.needs_resampling);
  std::vector<float> values(static_cast<std::size_t>(c.cols) * c.rows * g.slice_count());
  for (int m = 0; m < g.slice_count(); ++m)
    for (int j = 0; j < c.rows; ++j)
      for (int i = 0; i < c.cols; ++i)
        values[(static_cast<std::size_t>(m) * c.rows + j) * c.cols + i] =
            static_cast<float>(linear_field(g.sorted_positions[m] + g.axes.row * (i * c.px) +
                                            g.axes.column * (j * c.px)));
  SliceStackSamples in;
  in.values = values.data();
  in.columns = c.cols;
  in.rows = c.rows;
  in.slices = g.slice_count();
  in.positions = g.sorted_positions.data();
  in.row = g.axes.row;
  in.column = g.axes.column;
  in.spacing_x = in.spacing_y = c.px;
  std::vector<float> out(static_cast<std::size_t>(g.grid.dims.volume()), 0.0f);
  const auto stats = resample_slice_stack(in, g.grid, {kFill, false}, out.data());

  // Where both planes that bracket a voxel along the normal cover it, the value is trilinear and
  // exact for a linear field; where only the nearer one does (the wedges at the edges of a
  // tilted stack), it is that plane's value: off by at most the field's change over one gap.
  const Vec3d n = g.normal;
  auto covered = [&](int m, const Vec3d& q) {
    const Vec3d d = q - g.sorted_positions[m];
    const double u = dot(d, g.axes.row) / c.px, v = dot(d, g.axes.column) / c.px;
    return u >= -1e-3 && v >= -1e-3 && u <= c.cols - 1 + 1e-3 && v <= c.rows - 1 + 1e-3;
  };
  const double grad_n = std::abs(dot(Vec3d{3, -2, 5}, n));
  double widest_gap = 0;
  for (double gap : g.gaps_mm) widest_gap = std::max(widest_gap, gap);
  std::int64_t exact = 0, edge = 0, filled = 0;
  double worst_exact = 0, worst_edge = 0;
  for (int k = 0; k < g.grid.dims.z; ++k)
    for (int j = 0; j < g.grid.dims.y; ++j)
      for (int i = 0; i < g.grid.dims.x; ++i) {
        const float v = out[(static_cast<std::size_t>(k) * g.grid.dims.y + j) * g.grid.dims.x + i];
        if (v == kFill) {
          ++filled;
          continue;
        }
        const Vec3d q = g.grid.point(i, j, k);
        const double err = std::abs(static_cast<double>(v) - linear_field(q));
        const double t = dot(q - g.sorted_positions[0], n);
        int m = 0;
        while (m < g.slice_count() - 2 && g.offsets_mm[m + 1] <= t) ++m;
        if (covered(m, q) && covered(m + 1, q)) {
          ++exact;
          worst_exact = std::max(worst_exact, err);
        } else {
          ++edge;
          worst_edge = std::max(worst_edge, err);
        }
      }
  EXPECT_EQ(filled, stats.filled_voxels);
  EXPECT_GT(exact, g.grid.dims.volume() / 3);
  // float storage of values up to ~1000: a few ulps.
  EXPECT_LT(worst_exact, 2e-3) << "a linear field must be reproduced exactly inside the stack";
  EXPECT_LE(worst_edge, grad_n * widest_gap + 2e-3) << "edge voxels take the nearer plane";
  if (expect_fill)
    EXPECT_GT(filled, 0) << "a tilted stack's bounding box has corners outside it";
  else
    EXPECT_EQ(filled, 0);
}

TEST(SliceStackResampler, UnevenAxialStackReproducesALinearField) {
  Case c;
  c.row = {1, 0, 0};
  c.column = {0, 1, 0};
  double z = 10;
  for (double gap : {2.0, 2.0, 2.0, 0.7, 5.0, 5.0, 5.0, 10.0, 5.0}) {
    c.positions.push_back({-20, -15, z});
    z += gap;
  }
  c.positions.push_back({-20, -15, z});
  check_linear_field_is_reproduced(c, false);
}

TEST(SliceStackResampler, GantryTiltedStackReproducesALinearField) {
  // Tilt about the row axis (the scanner case): the fast row-aligned path.
  Case c;
  const double t = 18.5 * kPi / 180;
  c.row = {1, 0, 0};
  c.column = {0, std::cos(t), -std::sin(t)};
  double z = 0;
  for (int m = 0; m < 12; ++m) {
    c.positions.push_back({-20, -15, z});
    z += (m < 6 ? 4.0 : 7.0) / std::cos(t);
  }
  check_linear_field_is_reproduced(c, true);
}

TEST(SliceStackResampler, ObliqueShearReproducesALinearField) {
  // Oblique planes whose positions drift along both in-plane axes: the general path.
  Case c;
  c.row = normalized_or_zero(Vec3d{1, 0.2, 0.1});
  c.column = normalized_or_zero(cross(Vec3d{0.1, -0.3, 1}, c.row));
  const Vec3d normal = cross(c.row, c.column);
  const Vec3d drift = c.row * 0.3 + c.column * 0.25;
  for (int m = 0; m < 9; ++m)
    c.positions.push_back(Vec3d{5, -7, 2} + normal * (m * 3.0 + (m > 4 ? 1.5 : 0.0)) + drift * m);
  check_linear_field_is_reproduced(c, true);
}

TEST(SliceStackResampler, RoundingGivesWholeNumbers) {
  Case c;
  c.row = {1, 0, 0};
  c.column = {0, 1, 0};
  for (double z : {0.0, 1.0, 3.0, 4.0}) c.positions.push_back({0, 0, z});
  const auto g = analyze_slice_stack(c.positions, {c.row, c.column}, 1, 1, 4, 4);
  std::vector<float> values(4 * 4 * 4);
  for (std::size_t i = 0; i < values.size(); ++i) values[i] = static_cast<float>(i % 7) * 3.0f;
  SliceStackSamples in{values.data(), 4, 4, 4, g.sorted_positions.data(), c.row, c.column, 1, 1};
  std::vector<float> out(static_cast<std::size_t>(g.grid.dims.volume()));
  resample_slice_stack(in, g.grid, {0.0f, true}, out.data());
  bool fractional_before = false;
  std::vector<float> unrounded(out.size());
  resample_slice_stack(in, g.grid, {0.0f, false}, unrounded.data());
  for (std::size_t i = 0; i < out.size(); ++i) {
    EXPECT_EQ(out[i], std::nearbyint(out[i]));
    EXPECT_LE(std::abs(out[i] - unrounded[i]), 0.5f);
    fractional_before = fractional_before || unrounded[i] != std::nearbyint(unrounded[i]);
  }
  EXPECT_TRUE(fractional_before) << "the test needs interpolated fractions to round";
}

}  // namespace
}  // namespace tsf::import
