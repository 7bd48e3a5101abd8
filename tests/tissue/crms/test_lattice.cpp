// Lattice construction: analytic boxes, voxel volumes at node spacings 1, 2, 4, 8, anchors,
// topology edits and the rest-point → cell mapping for the coupler.
#include <gtest/gtest.h>

#include <cmath>

#include "tsf/common/error.h"
#include "tsf/crms/lattice_builders.h"
#include "tsf/crms/node_state_view.h"
#include "tsf/volume/tissue_labels.h"

namespace tsf::crms {
namespace {

TEST(CrmsLattice, BoxTilesItsExtentExactly) {
  BoxLatticeOptions o;
  o.size_mm = {40.0, 10.0, 7.0};
  o.spacing_mm = 2.5;
  o.min_corner_mm = {-20.0, 0.0, 1.0};
  const Lattice l = build_box_lattice(o);
  const LatticeGeometry& g = l.geometry();
  EXPECT_EQ(g.dims, (Int3{16, 4, 3}));
  EXPECT_DOUBLE_EQ(g.spacing.x, 2.5);
  EXPECT_DOUBLE_EQ(g.spacing.z, 7.0 / 3.0);  // adjusted so that 3 cells tile 7 mm
  EXPECT_DOUBLE_EQ(g.origin.x, -20.0 + 1.25);
  EXPECT_EQ(l.alive_count(), 16 * 4 * 3);
  // Mass = density × volume of the box.
  EXPECT_NEAR(l.total_mass(), 1e-3 * 40.0 * 10.0 * 7.0, 1e-6);  // float masses
  // An interior node has all six links; a corner node three.
  EXPECT_EQ(l.packed_flags(g.index(5, 1, 1)) & kLinkBits, 0x3f);
  EXPECT_EQ(__builtin_popcount(l.packed_flags(g.index(0, 0, 0)) & kLinkBits), 3);
}

TEST(CrmsLattice, BadBoxOptionsAreRejectedWithTheField) {
  BoxLatticeOptions o;
  o.spacing_mm = -1.0;
  try {
    build_box_lattice(o);
    FAIL() << "a negative spacing was accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("spacing"), std::string::npos) << e.what();
  }
  o.spacing_mm = 1.0;
  o.density_g_per_mm3 = 5.0;
  EXPECT_THROW(build_box_lattice(o), Error);
}

/// A 16³ volume holding a sphere of radius 6 voxels with a smooth edge, bone below z = 4.
VoxelVolume sphere_volume(Vec3d spacing) {
  VolumeGeometry g;
  g.dims = {16, 16, 16};
  g.spacing = spacing;
  g.origin = {10.0, -5.0, 2.0};
  VoxelVolume v(g);
  for (int k = 0; k < 16; ++k)
    for (int j = 0; j < 16; ++j)
      for (int i = 0; i < 16; ++i) {
        const double r =
            std::sqrt((i - 7.5) * (i - 7.5) + (j - 7.5) * (j - 7.5) + (k - 7.5) * (k - 7.5));
        const double d = std::clamp(6.5 - r, 0.0, 1.0);
        const std::size_t n = v.index(i, j, k);
        v.density_data()[n] = static_cast<float>(d);
        v.label_data()[n] = d > 0 ? (k < 4 ? kLabelCorticalBone : kLabelSoftTissue) : 0;
      }
  return v;
}

TEST(CrmsLattice, VolumeLatticeAtSpacings1248) {
  const VoxelVolume vol = sphere_volume({0.5, 0.5, 0.8});
  double voxel_mass = 0;
  for (float d : vol.density_data()) voxel_mass += 1e-3 * 0.5 * 0.5 * 0.8 * static_cast<double>(d);
  for (int k : {1, 2, 4, 8}) {
    VolumeLatticeOptions o;
    o.node_spacing_voxels = k;
    o.mass_floor = 0.0f;
    const Lattice l = build_lattice_from_volume(vol, o);
    const LatticeGeometry& g = l.geometry();
    EXPECT_EQ(g.dims.x, 16 / k);
    EXPECT_DOUBLE_EQ(g.spacing.z, 0.8 * k);
    // Node (0,0,0) sits at the centre of its k³ block of voxels.
    EXPECT_DOUBLE_EQ(g.origin.x, 10.0 + 0.5 * (0.5 * k - 0.5));
    // Every alive node reaches the threshold, every dead one does not.
    for (std::int64_t n = 0; n < l.node_count(); ++n)
      EXPECT_EQ(l.alive(n), l.occupancy(n) >= 0.125f) << "k = " << k << " node " << n;
    // Without a mass floor, mass is the tissue mass of the alive cells: at most the voxel mass,
    // and close to it (only cells below the threshold are lost).
    EXPECT_LE(l.total_mass(), voxel_mass * (1 + 1e-6));
    EXPECT_GT(l.total_mass(), 0.9 * voxel_mass) << "k = " << k;
  }
}

TEST(CrmsLattice, MassFloorKeepsSurfaceNodesHeavyEnough) {
  const VoxelVolume vol = sphere_volume({1, 1, 1});
  VolumeLatticeOptions o;
  o.node_spacing_voxels = 2;
  o.mass_floor = 0.5f;
  const Lattice l = build_lattice_from_volume(vol, o);
  const double full = 1e-3 * 8.0;
  for (std::int64_t n = 0; n < l.node_count(); ++n)
    if (l.alive(n)) {
      EXPECT_GE(l.mass(n), 0.5 * full - 1e-9);
    }
}

TEST(CrmsLattice, AnchorsFromLabelsBoxesAndPlanes) {
  VolumeLatticeOptions o;
  o.node_spacing_voxels = 2;
  o.fixed_labels = {kLabelCorticalBone};
  Lattice l = build_lattice_from_volume(sphere_volume({1, 1, 1}), o);
  std::int64_t fixed = 0;
  for (std::int64_t n = 0; n < l.node_count(); ++n) {
    if (l.fixed(n)) {
      ++fixed;
      EXPECT_EQ(l.label(n), kLabelCorticalBone);
    }
  }
  EXPECT_GT(fixed, 0);

  Lattice b = build_box_lattice({});
  EXPECT_EQ(fix_nodes_behind_plane(b, {0, 0, 1.0}, {0, 0, 1}), 10 * 10);  // bottom layer
  EXPECT_EQ(fix_nodes_in_box(b, {-1, -1, 9}, {11, 11, 11}), 10 * 10);     // top layer
  EXPECT_THROW(fix_nodes_behind_plane(b, {0, 0, 0}, {0, 0, 0}), Error);
}

TEST(CrmsLattice, EmptyVolumeIsRejected) {
  VolumeGeometry g;
  g.dims = {4, 4, 4};
  const VoxelVolume v(g);
  EXPECT_THROW(build_lattice_from_volume(v, {}), Error);
  VolumeLatticeOptions o;
  o.occupancy_threshold = 0.0f;
  EXPECT_THROW(build_lattice_from_volume(sphere_volume({1, 1, 1}), o), Error);
}

TEST(CrmsLattice, BrokenSpringsAndDeletedNodesClearLinksOnBothEnds) {
  Lattice l = build_box_lattice({});
  const LatticeGeometry& g = l.geometry();
  const std::int64_t a = g.index(3, 3, 3), b = g.index(4, 3, 3);
  l.break_spring(a, 1);  // +x
  EXPECT_FALSE(l.link(a, 1));
  EXPECT_FALSE(l.link(b, 0));
  EXPECT_TRUE(l.link(a, 0));
  EXPECT_EQ(l.broken_mask(b), 1u << 0);
  const std::int64_t c = g.index(5, 5, 5);
  l.set_alive(c, false);
  for (int d = 0; d < 6; ++d) EXPECT_FALSE(l.link(l.neighbour(c, d), opposite_direction(d)));
  EXPECT_EQ(l.packed_flags(c), 0);
}

TEST(CrmsLattice, RestPointMapsToItsCubeAndLocalCoordinates) {
  BoxLatticeOptions o;
  o.size_mm = {8, 8, 8};
  o.spacing_mm = 2;
  const Lattice l = build_box_lattice(o);  // nodes at 1, 3, 5, 7 mm
  const LatticeCellLocation a = locate_rest_point(l.geometry(), {3.5, 1.0, 6.9});
  EXPECT_EQ(a.cell, (Int3{1, 0, 2}));
  EXPECT_NEAR(a.local.x, 0.25, 1e-12);
  EXPECT_NEAR(a.local.y, 0.0, 1e-12);
  EXPECT_NEAR(a.local.z, 0.95, 1e-12);
  EXPECT_TRUE(a.inside_hull);
  // Within the outer half cell (between the last node layer and the box surface).
  const LatticeCellLocation b = locate_rest_point(l.geometry(), {0.2, 7.8, 4.0});
  EXPECT_EQ(b.cell, (Int3{0, 2, 1}));
  EXPECT_NEAR(b.local.x, -0.4, 1e-12);
  EXPECT_NEAR(b.local.y, 1.4, 1e-12);
  EXPECT_FALSE(b.inside_hull);
  // Far away and NaN points never overflow.
  const LatticeCellLocation c = locate_rest_point(l.geometry(), {1e30, -1e30, std::nan("")});
  EXPECT_EQ(c.cell, (Int3{2, 0, 0}));
  EXPECT_FALSE(c.inside_hull);
}

}  // namespace
}  // namespace tsf::crms
