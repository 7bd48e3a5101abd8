#include "tsf/volume/volume_edits.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <string>

#include "tsf/common/error.h"
#include "tsf/volume/analytic_volumes.h"

namespace tsf {
namespace {

VoxelVolume solid(const Int3& dims, std::uint8_t label = kLabelSoftTissue, double spacing = 1.0) {
  VoxelVolume v(cube_geometry(dims, spacing));
  auto& d = v.density_data();
  std::fill(d.begin(), d.end(), 1.0f);
  std::fill(v.label_data().begin(), v.label_data().end(), label);
  v.mark_all_modified();
  return v;
}

/// Box of voxels whose density or label differ between a and b.
VoxelBox difference(const VoxelVolume& a, const VoxelVolume& b) {
  VoxelBox box{};
  for (int k = 0; k < a.dims().z; ++k)
    for (int j = 0; j < a.dims().y; ++j)
      for (int i = 0; i < a.dims().x; ++i)
        if (a.density(i, j, k) != b.density(i, j, k) || a.label(i, j, k) != b.label(i, j, k))
          box.include(i, j, k);
  return box;
}

void expect_ranges_current(const VoxelVolume& v) {
  ASSERT_TRUE(v.brick_ranges_current());
  for (int bk = 0; bk < v.brick_dims().z; ++bk)
    for (int bj = 0; bj < v.brick_dims().y; ++bj)
      for (int bi = 0; bi < v.brick_dims().x; ++bi) {
        const VoxelBox b = v.brick_box(bi, bj, bk);
        float lo = 2, hi = -1;
        for (int k = b.lo.z; k < b.hi.z; ++k)
          for (int j = b.lo.y; j < b.hi.y; ++j)
            for (int i = b.lo.x; i < b.hi.x; ++i) {
              lo = std::min(lo, v.density(i, j, k));
              hi = std::max(hi, v.density(i, j, k));
            }
        const auto& r = v.brick_ranges()[v.brick_index(bi, bj, bk)];
        ASSERT_EQ(r.min, lo) << "brick " << bi << "," << bj << "," << bk;
        ASSERT_EQ(r.max, hi) << "brick " << bi << "," << bj << "," << bk;
      }
}

TEST(VolumeEdits, AblatedSphereRemovesTheSphereVolume) {
  VoxelVolume v = solid({48, 48, 48}, kLabelSoftTissue, 0.5);
  const SphereTool tool{{12.0, 12.0, 12.0}, 6.0};  // mm: voxel (24,24,24), radius 12 voxels
  ablate_sphere(v, tool);
  double removed = 0;
  for (float d : v.density_data()) removed += 1.0 - static_cast<double>(d);
  const double voxel = 0.125;  // mm³
  const double expected = 4.0 / 3.0 * M_PI * std::pow(tool.radius, 3);
  EXPECT_NEAR(removed * voxel, expected, 0.02 * expected);
  // The iso-level sits on the tool surface: inside < 0.5, outside > 0.5 one voxel away.
  EXPECT_LT(v.density(24, 24, 24), 0.01f);
  EXPECT_GT(v.density(24 + 13, 24, 24), 0.99f);
  EXPECT_NEAR(v.density(24 + 12, 24, 24), 0.5f, 0.08f);
}

TEST(VolumeEdits, ReportedBoxIsExactlyTheChangedVoxels) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(0, 1);
  VoxelVolume v = make_blob_volume(cube_geometry({40, 36, 32}, 0.8), 3);
  for (int i = 0; i < 40; ++i) {
    const VoxelVolume before = v;
    const Vec3d c{u(rng) * 32, u(rng) * 29, u(rng) * 26};
    VoxelBox reported;
    switch (i % 4) {
      case 0:
        reported = ablate_sphere(v, {c, 1 + 3 * u(rng)});
        break;
      case 1:
        reported = ablate_capsule(v, {c, c + Vec3d{4, -3, 2}, 1.5});
        break;
      case 2:
        reported = cut_swept_blade(v, {{4, 2, 0.3}}, {c, Rotation{}},
                                   {c + Vec3d{0, 0, 5}, Rotation::about_axis({1, 0, 0}, 0.4)});
        break;
      default:
        reported = set_box(v, c, c + Vec3d{3, 2, 4}, 0.7f, kLabelFat);
        break;
    }
    EXPECT_EQ(reported, difference(before, v)) << "edit " << i;
  }
  expect_ranges_current(v);
}

TEST(VolumeEdits, LabelRatesSlowCartilageDown) {
  VoxelVolume v = solid({24, 24, 24}, kLabelMucosa);
  // Left half cartilage, right half mucosa.
  for (int k = 0; k < 24; ++k)
    for (int j = 0; j < 24; ++j)
      for (int i = 0; i < 12; ++i) v.label_data()[v.index(i, j, k)] = kLabelCartilage;
  RemovalOptions o;
  o.rates = LabelRates::tissue_defaults();
  o.strength = 0.5f;
  ablate_capsule(v, {{4, 12, 12}, {20, 12, 12}, 3.0}, o);
  EXPECT_NEAR(v.density(6, 12, 12), 1.0f - 0.5f * 0.35f, 1e-5f);  // cartilage, deep inside
  EXPECT_NEAR(v.density(18, 12, 12), 0.5f, 1e-5f);                // mucosa
  EXPECT_EQ(v.label(18, 12, 12), kLabelMucosa);                   // removal never relabels
}

TEST(VolumeEdits, SweptBladeCutsASlabThroughABlock) {
  VoxelVolume v = solid({40, 40, 40});
  // A blade 30 mm long (x), 6 mm deep (y), 0.6 mm thick (z), swept down through the block in y.
  const BladeTool blade{{15.0, 3.0, 0.3}};
  cut_swept_blade(v, blade, {{20, -4, 20}, Rotation{}}, {{20, 44, 20}, Rotation{}});
  for (int j = 2; j < 38; ++j) {
    EXPECT_LT(v.density(20, j, 20), 0.5f) << "y " << j;   // on the cut plane
    EXPECT_GT(v.density(20, j, 22), 0.99f) << "y " << j;  // two voxels off it
    EXPECT_GT(v.density(36, j, 20), 0.99f) << "y " << j;  // beyond the blade's length
  }
  // A rotating sweep covers the arc between the poses, not only the end poses.
  VoxelVolume w = solid({40, 40, 40});
  cut_swept_blade(w, {{10.0, 0.5, 0.5}}, {{20, 20, 20}, Rotation{}},
                  {{20, 20, 20}, Rotation::about_axis({0, 0, 1}, M_PI / 2)});
  const double a = M_PI / 4;  // halfway
  EXPECT_LT(w.density(static_cast<int>(std::lround(20 + 7 * std::cos(a))),
                      static_cast<int>(std::lround(20 + 7 * std::sin(a))), 20),
            0.5f);
}

TEST(VolumeEdits, ObliqueSweptBladeEmptiesEveryVoxelDeepInsideItsEndPoses) {
  // A blade tilted about an oblique axis (its bounding box is far from axis-aligned), swept and
  // turned: every voxel more than the falloff (1 voxel) inside the blade at either end pose is
  // emptied, and a voxel more than the falloff outside the blade at every sub-step's pose is
  // untouched (the per-sub-step bounding box must not clip the blade's corners).
  VoxelVolume v = solid({48, 48, 48});
  const VoxelVolume before = v;
  const BladeTool blade{{12.0, 6.0, 1.5}};
  const ToolPose from{{20, 22, 21}, Rotation::about_axis({1, 2, 3}, 0.9)};
  const ToolPose to{{27, 25, 26}, Rotation::about_axis({-2, 1, 1}, 0.7)};
  cut_swept_blade(v, blade, from, to);
  int deep = 0;
  for (int k = 0; k < 48; ++k)
    for (int j = 0; j < 48; ++j)
      for (int i = 0; i < 48; ++i) {
        const Vec3d p{double(i), double(j), double(k)};
        const double d = std::min(blade_distance(blade, from, p), blade_distance(blade, to, p));
        if (d < -1.0) {
          ++deep;
          EXPECT_EQ(v.density(i, j, k), 0.0f) << i << " " << j << " " << k;
        }
      }
  EXPECT_GT(deep, 300);
  // Far from the whole sweep (beyond the blade's corner distance from every point of the path
  // plus the falloff): untouched.
  const double corner = length(blade.half_extents);
  for (int k = 0; k < 48; ++k)
    for (int j = 0; j < 48; ++j)
      for (int i = 0; i < 48; ++i) {
        const Vec3d p{double(i), double(j), double(k)};
        const Vec3d ab = to.position - from.position;
        const double t = std::clamp(dot(p - from.position, ab) / dot(ab, ab), 0.0, 1.0);
        if (length(p - (from.position + ab * t)) > corner + 1.5) {
          EXPECT_EQ(v.density(i, j, k), before.density(i, j, k)) << i << " " << j << " " << k;
        }
      }
}

TEST(VolumeEdits, SetBoxSetsDensityAndLabel) {
  VoxelVolume v(cube_geometry({16, 16, 16}));
  const VoxelBox b = set_box(v, {2.0, 3.0, 4.0}, {5.0, 6.0, 7.0}, 1.0f, kLabelTumour);
  EXPECT_EQ(b, (VoxelBox{{2, 3, 4}, {6, 7, 8}}));
  EXPECT_EQ(v.density(2, 3, 4), 1.0f);
  EXPECT_EQ(v.label(5, 6, 7), kLabelTumour);
  EXPECT_EQ(v.density(6, 6, 7), 0.0f);
  // Setting what is already there changes nothing.
  EXPECT_TRUE(set_box(v, {2.0, 3.0, 4.0}, {5.0, 6.0, 7.0}, 1.0f, kLabelTumour).empty());
  expect_ranges_current(v);
}

TEST(VolumeEdits, LabelShapesRelabelTissueAndKeepDensity) {
  VoxelVolume v = solid({20, 20, 20});
  v.density_data()[v.index(10, 5, 10)] = 0.0f;  // air inside the capsule stays unlabelled
  v.mark_all_modified();
  const VoxelVolume before = v;
  const VoxelBox changed = label_capsule(v, {{10, 2, 10}, {10, 17, 10}, 1.5}, kLabelVessel);
  EXPECT_EQ(changed, difference(before, v));
  EXPECT_EQ(v.label(10, 10, 10), kLabelVessel);
  EXPECT_EQ(v.label(11, 10, 11), kLabelVessel);      // 1.41 mm from the axis
  EXPECT_EQ(v.label(12, 10, 10), kLabelSoftTissue);  // 2 mm
  EXPECT_EQ(v.label(10, 5, 10), kLabelSoftTissue);   // no tissue there
  for (std::size_t i = 0; i < v.density_data().size(); ++i)
    EXPECT_EQ(v.density_data()[i], before.density_data()[i]);
  const VoxelBox boxed = label_box(v, {0, 0, 0}, {4, 19, 19}, kLabelCorticalBone);
  EXPECT_EQ(boxed.lo.x, 0);
  EXPECT_EQ(boxed.hi.x, 5);
  EXPECT_EQ(v.label(4, 3, 3), kLabelCorticalBone);
  EXPECT_EQ(v.label(5, 3, 3), kLabelSoftTissue);
}

TEST(VolumeEdits, ClearVoxelsEmptiesTheBoxesAndReportsWhatChanged) {
  VoxelVolume v = solid({12, 12, 12});
  const VoxelVolume before = v;
  const VoxelBox changed = clear_voxels(
      v, {{{2, 2, 2}, {4, 3, 3}}, {{8, 8, 8}, {20, 9, 9}}, {{-5, -5, -5}, {-1, 0, 0}}});
  EXPECT_EQ(changed, difference(before, v));
  EXPECT_EQ(v.density(3, 2, 2), 0.0f);
  EXPECT_EQ(v.density(11, 8, 8), 0.0f);  // clipped to the volume
  EXPECT_EQ(v.density(4, 2, 2), 1.0f);
  EXPECT_EQ(v.label(3, 2, 2), kLabelSoftTissue);  // labels stay
  EXPECT_TRUE(clear_voxels(v, {{{2, 2, 2}, {4, 3, 3}}}).empty()) << "nothing left to clear";
}

TEST(VolumeEdits, ToolsOutsideTheVolumeChangeNothing) {
  VoxelVolume v = solid({8, 8, 8});
  EXPECT_TRUE(ablate_sphere(v, {{100, 100, 100}, 3}).empty());
  EXPECT_TRUE(set_box(v, {-9, -9, -9}, {-5, -5, -5}, 0.0f).empty());
}

TEST(VolumeEdits, BadToolsAreRejectedWithTheFieldNamed) {
  VoxelVolume v = solid({8, 8, 8});
  RemovalOptions o;
  o.strength = 1.5f;
  try {
    ablate_sphere(v, {{4, 4, 4}, 2}, o);
    FAIL() << "strength 1.5 accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("strength"), std::string::npos) << e.what();
  }
  EXPECT_THROW(ablate_sphere(v, {{4, 4, 4}, std::nan("")}), Error);
  EXPECT_THROW(set_box(v, {0, 0, 0}, {2, 2, 2}, -0.1f), Error);
  EXPECT_THROW(cut_swept_blade(v, {{-1, 1, 1}}, {}, {}), Error);
  o.strength = 1.0f;
  o.rates.rate[kLabelFat] = 2.0f;
  EXPECT_THROW(ablate_sphere(v, {{4, 4, 4}, 2}, o), Error);
}

TEST(VoxelVolumeBricks, RangesAndStampsFollowEdits) {
  VoxelVolume v = solid({20, 17, 9});
  EXPECT_EQ(v.brick_dims(), (Int3{3, 3, 2}));
  expect_ranges_current(v);
  const std::uint64_t stamp = v.modification_count();
  const VoxelBox changed = ablate_sphere(v, {{3, 3, 3}, 2});
  ASSERT_FALSE(changed.empty());
  EXPECT_GT(v.modification_count(), stamp);
  const auto bricks = v.bricks_modified_since(stamp);
  ASSERT_EQ(bricks.size(), 1u);
  EXPECT_EQ(bricks[0], v.brick_index(0, 0, 0));
  EXPECT_EQ(v.modified_since(stamp), v.brick_box(0, 0, 0));
  EXPECT_TRUE(v.modified_since(v.modification_count()).empty());
  expect_ranges_current(v);
}

TEST(VoxelVolumeBricks, WritableDensityMarksRangesStaleUntilRefreshed) {
  VoxelVolume v = solid({10, 10, 10});
  v.density_data()[v.index(9, 9, 9)] = 0.25f;
  EXPECT_FALSE(v.brick_ranges_current());
  v.mark_all_modified();
  expect_ranges_current(v);
  EXPECT_EQ(v.brick_ranges()[v.brick_index(1, 1, 1)].min, 0.25f);
}

}  // namespace
}  // namespace tsf
