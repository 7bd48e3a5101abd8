// Slice-stack geometry from positions and orientation alone (synthetic stacks).
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "tsf/common/error.h"
#include "tsf/import/slice_stack_geometry.h"

namespace tsf::import {
namespace {

constexpr double kPi = 3.14159265358979323846;

/// Positions of slices stacked along `step_dir` with the given gaps along it.
std::vector<Vec3d> stack(const Vec3d& origin, const Vec3d& step_dir,
                         const std::vector<double>& gaps) {
  std::vector<Vec3d> p{origin};
  for (double g : gaps) p.push_back(p.back() + step_dir * g);
  return p;
}

void expect_orthonormal(const OrthogonalGrid& g) {
  for (int a = 0; a < 3; ++a) {
    EXPECT_NEAR(length(g.axes[a]), 1.0, 1e-12);
    for (int b = a + 1; b < 3; ++b) EXPECT_NEAR(dot(g.axes[a], g.axes[b]), 0.0, 1e-12);
  }
  EXPECT_NEAR(dot(cross(g.axes[0], g.axes[1]), g.axes[2]), 1.0, 1e-12) << "right-handed";
}

TEST(SliceStackGeometry, EvenAxialStackIsKeptAsAcquired) {
  const auto p = stack({-100, -120, 30}, {0, 0, 1}, std::vector<double>(19, 2.5));
  // Shuffle: the analysis sorts by position, not by input order.
  std::vector<Vec3d> shuffled = {p[5], p[0], p[19], p[3]};
  for (int i = 0; i < 20; ++i)
    if (i != 5 && i != 0 && i != 19 && i != 3) shuffled.push_back(p[i]);
  const auto g = analyze_slice_stack(shuffled, {{1, 0, 0}, {0, 1, 0}}, 0.5, 0.6, 512, 400);
  EXPECT_FALSE(g.needs_resampling);
  EXPECT_FALSE(g.uneven);
  EXPECT_FALSE(g.tilted);
  EXPECT_TRUE(g.missing.empty());
  EXPECT_EQ(g.sorted[0], 1);
  EXPECT_EQ(g.sorted[19], 2);
  EXPECT_EQ(g.grid.dims.x, 512);
  EXPECT_EQ(g.grid.dims.y, 400);
  EXPECT_EQ(g.grid.dims.z, 20);
  EXPECT_NEAR(g.grid.spacing.z, 2.5, 1e-12);
  EXPECT_NEAR(g.grid.spacing.x, 0.5, 1e-12);
  EXPECT_NEAR(g.grid.origin.z, 30, 1e-12);
  expect_orthonormal(g.grid);
}

TEST(SliceStackGeometry, UnevenGapsAreGroupedAndResampledOverTheExactSpan) {
  std::vector<double> gaps(5, 4.0);
  gaps.push_back(1.0);
  for (int i = 0; i < 5; ++i) gaps.push_back(7.0);
  const auto p = stack({0, 0, 0}, {0, 0, 1}, gaps);
  const auto g = analyze_slice_stack(p, {{1, 0, 0}, {0, 1, 0}}, 1, 1, 64, 64);
  EXPECT_TRUE(g.uneven);
  EXPECT_TRUE(g.needs_resampling);
  EXPECT_FALSE(g.tilted);
  ASSERT_EQ(g.gap_runs.size(), 3u);
  EXPECT_NEAR(g.gap_runs[0].gap_mm, 4.0, 1e-9);
  EXPECT_EQ(g.gap_runs[0].count, 5);
  EXPECT_EQ(g.gap_runs[1].count, 1);
  EXPECT_EQ(g.gap_runs[2].count, 5);
  EXPECT_NEAR(g.regular_gap_mm, 4.0, 1e-9) << "the 1 mm gap is an outlier, 4 mm the finest run";
  EXPECT_TRUE(g.missing.empty()) << "a run of 7 mm gaps is a protocol change, not lost slices";
  const double span = 5 * 4.0 + 1.0 + 5 * 7.0;
  EXPECT_NEAR((g.grid.dims.z - 1) * g.grid.spacing.z, span, 1e-9);
  EXPECT_NEAR(g.grid.spacing.z, 4.0, 0.5 * 4.0 / (g.grid.dims.z - 1) + 1e-9);
  EXPECT_EQ(describe_gap_runs(g.gap_runs), "4.00 mm ×5, 1.00 mm ×1, 7.00 mm ×5");
}

TEST(SliceStackGeometry, IsolatedDoubleGapIsReportedAsAMissingSlice) {
  const auto p = stack({0, 0, 0}, {0, 0, -1}, {5, 5, 5, 10, 5, 5, 5, 15.2, 5, 5});
  // IOP with the normal along -z (feet-first axial): offsets grow toward -z.
  const auto g = analyze_slice_stack(p, {{-1, 0, 0}, {0, 1, 0}}, 1, 1, 8, 8);
  ASSERT_EQ(g.missing.size(), 2u);
  EXPECT_EQ(g.missing[0].after_slice, 3);
  EXPECT_EQ(g.missing[0].estimated_missing, 1);
  EXPECT_EQ(g.missing[1].estimated_missing, 2);
  EXPECT_TRUE(g.needs_resampling);
  EXPECT_NEAR(g.regular_gap_mm, 5.0, 1e-9);
}

TEST(SliceStackGeometry, DuplicatePositionsAreReturnedNotResolved) {
  auto p = stack({0, 0, 0}, {0, 0, 1}, {3, 3, 3});
  p.push_back(p[2] + Vec3d{0, 0, 0.004});  // same plane within 0.01 mm
  const auto g = analyze_slice_stack(p, {{1, 0, 0}, {0, 1, 0}}, 1, 1, 8, 8);
  ASSERT_EQ(g.duplicates.size(), 1u);
  EXPECT_EQ(g.duplicates[0].slices.size(), 2u);
}

TEST(SliceStackGeometry, GantryTiltIsMeasuredAndResolvedOntoTheTableAxis) {
  // GE-like: rows along x, columns tilted 18.5° about x, table moves along +z (4 then 7 mm along
  // the normal).
  const double tilt = 18.5 * kPi / 180;
  const Vec3d row{1, 0, 0}, column{0, std::cos(tilt), -std::sin(tilt)};
  std::vector<double> gaps(6, 4.0 / std::cos(tilt));
  for (int i = 0; i < 6; ++i) gaps.push_back(7.0 / std::cos(tilt));
  const auto p = stack({-125, -123.5, 5.8}, {0, 0, 1}, gaps);
  const int cols = 512, rows = 512;
  const double px = 0.488;
  const auto g = analyze_slice_stack(p, {row, column}, px, px, cols, rows);
  EXPECT_TRUE(g.tilted);
  EXPECT_NEAR(g.tilt_deg, 18.5, 1e-6);
  EXPECT_TRUE(g.uneven);
  EXPECT_NEAR(g.gap_runs[0].gap_mm, 4.0, 1e-9) << "gaps are measured along the slice normal";
  EXPECT_FALSE(g.tilt_resolution.empty());
  expect_orthonormal(g.grid);
  EXPECT_NEAR(dot(g.grid.axes[2], Vec3d{0, 0, 1}), 1.0, 1e-12) << "z follows the table";
  EXPECT_NEAR(dot(g.grid.axes[0], row), 1.0, 1e-12) << "x follows the image rows";
  EXPECT_NEAR(g.grid.spacing.x, px, 1e-12);
  // The grid is the bounding box of every acquired pixel centre.
  for (const Vec3d& pos : p)
    for (int c = 0; c < 4; ++c) {
      const Vec3d corner =
          pos + row * (c & 1 ? (cols - 1) * px : 0.0) + column * (c & 2 ? (rows - 1) * px : 0.0);
      for (int a = 0; a < 3; ++a) {
        const double coord = dot(corner - g.grid.origin, g.grid.axes[a]);
        const double extent = (g.grid.dims[a] - 1) * g.grid.spacing[a];
        EXPECT_GE(coord, -1e-6);
        EXPECT_LE(coord, extent + 1e-6);
      }
    }
  // Along z the box is exactly the span of the stack's corners.
  const double z_lo = std::min(p.front().z, p.front().z + column.z * (rows - 1) * px);
  const double z_hi = std::max(p.back().z, p.back().z + column.z * (rows - 1) * px);
  EXPECT_NEAR(g.grid.origin.z, z_lo, 1e-9);
  EXPECT_NEAR((g.grid.dims.z - 1) * g.grid.spacing.z, z_hi - z_lo, 1e-9);
}

TEST(SliceStackGeometry, TinyInPlaneJitterIsNotATilt) {
  auto p = stack({0, 0, 0}, {0, 0, 1}, std::vector<double>(9, 2.0));
  for (std::size_t i = 0; i < p.size(); ++i) p[i].x += (i % 2 ? 1e-3 : -1e-3);  // DS rounding
  const auto g = analyze_slice_stack(p, {{1, 0, 0}, {0, 1, 0}}, 0.5, 0.5, 16, 16);
  EXPECT_FALSE(g.tilted);
  EXPECT_FALSE(g.needs_resampling);
}

TEST(SliceStackGeometry, RequestedResampledSpacingIsHonoured) {
  const auto p = stack({0, 0, 0}, {0, 0, 1}, {2, 2, 3, 2, 2});
  SliceStackOptions o;
  o.resampled_slice_spacing_mm = 0.5;
  const auto g = analyze_slice_stack(p, {{1, 0, 0}, {0, 1, 0}}, 1, 1, 8, 8, o);
  EXPECT_EQ(g.grid.dims.z, 23);
  EXPECT_NEAR(g.grid.spacing.z, 0.5, 1e-12);
}

TEST(SliceStackGeometry, BrokenInputsAreRefusedWithTheReason) {
  const PlaneAxes axial{{1, 0, 0}, {0, 1, 0}};
  try {
    analyze_slice_stack({{0, 0, 0}}, axial, 1, 1, 8, 8);
    FAIL() << "one slice accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("at least 2 slices"), std::string::npos) << e.what();
  }
  try {
    analyze_slice_stack({{0, 0, 0}, {0, 0, 1}}, {{1, 0, 0}, {0.2, 1, 0}}, 1, 1, 8, 8);
    FAIL() << "non-orthogonal orientation accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("not orthogonal"), std::string::npos) << e.what();
  }
  EXPECT_THROW(analyze_slice_stack({{0, 0, 0}, {0, 0, 1}}, axial, 0, 1, 8, 8), Error);
  EXPECT_THROW(analyze_slice_stack({{0, 0, 0}, {0, 0, NAN}}, axial, 1, 1, 8, 8), Error);
  // Positions a light-year apart: a grid that cannot exist is refused, not overflowed.
  EXPECT_THROW(analyze_slice_stack({{0, 0, 0}, {0, 0, 1}, {0, 0, 1e15}}, axial, 1, 1, 8, 8), Error);
}

}  // namespace
}  // namespace tsf::import
