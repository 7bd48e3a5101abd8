// Building CRMS lattices: from a voxel volume (the product path) and from analytic boxes (tests,
// benchmarks, scenes), plus anchors from labels or scene shapes.
//
// From a volume with node spacing k voxels: node (a,b,c) owns the k³ voxels [a·k, (a+1)·k)³ and
// sits at their centre, i.e. at continuous voxel index (a + ½)·k − ½ per axis; spacing = k × voxel
// spacing (mm, per axis). Occupancy = mean voxel density over the block (voxels beyond the volume
// count as empty). A node exists where occupancy ≥ threshold (default 1/8, DESIGN R3).
// Mass = ρ · cell volume · max(occupancy, mass_floor): the floor keeps thin surface cells from
// becoming so light that they set the stable time step (ω ∝ 1/√m); it adds at most
// (mass_floor − threshold) of a cell's mass per surface node, reported by total_mass().
// Heterogeneous tissue (material_blends): each node's MaterialBlend is the density-weighted mean
// of its cell's voxel material weights (segment's 4 channels), channel c standing for palette
// entry channel_material[c]; ρ is then the same blend of the channels' densities.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "tsf/common/vec3.h"
#include "tsf/crms/lattice.h"
#include "tsf/volume/voxel_volume.h"

namespace tsf::crms {

struct VolumeLatticeOptions {
  int node_spacing_voxels = 2;             ///< k: 1, 2, 4 or 8 (any k ≥ 1 is accepted)
  float occupancy_threshold = 0.125f;      ///< a node exists at occupancy ≥ this, in (0,1]
  float mass_floor = 0.5f;                 ///< see header; in [0,1]
  double density_g_per_mm3 = 1.0e-3;       ///< tissue mass density (water 1e-3)
  std::vector<std::uint8_t> fixed_labels;  ///< nodes whose label is listed are anchored
  /// Per-node blends from the volume's material weights (it must carry them; see header).
  bool material_blends = false;
  std::array<int, 4> channel_material{0, 1, 2, 3};  ///< palette entry of each channel, 0..15
  std::array<double, 4> channel_density_g_per_mm3{1.0e-3, 1.0e-3, 1.0e-3, 1.0e-3};
};

/// The blend of up to 4 palette entries with the given non-negative fractions (any positive sum):
/// entries named twice merge, weights are rounded to 1/255 keeping the sum exactly 255 (largest
/// remainders first). All-zero fractions give entries[0] alone.
MaterialBlend make_material_blend(const std::array<int, 4>& entries,
                                  const std::array<double, 4>& fractions);

/// Throws tsf::Error naming the option when a value is out of range or the volume is empty.
Lattice build_lattice_from_volume(const VoxelVolume& volume, const VolumeLatticeOptions& options);

struct BoxLatticeOptions {
  Vec3d size_mm{10.0, 10.0, 10.0};  ///< box extent; each axis gets round(size/spacing) ≥ 1 nodes
  double spacing_mm = 1.0;          ///< requested spacing; adjusted per axis to tile size exactly
  Vec3d min_corner_mm{0.0, 0.0, 0.0};
  double density_g_per_mm3 = 1.0e-3;
};

/// A solid box: every node alive with occupancy 1 and mass ρ·hx·hy·hz, label soft tissue.
Lattice build_box_lattice(const BoxLatticeOptions& options);

/// Anchors every alive node whose rest position lies in the closed box [lo, hi]; returns how many.
std::int64_t fix_nodes_in_box(Lattice& lattice, const Vec3d& lo, const Vec3d& hi);
/// Anchors every alive node whose rest position p satisfies (p − point)·normal ≤ 0.
std::int64_t fix_nodes_behind_plane(Lattice& lattice, const Vec3d& point, const Vec3d& normal);
/// Anchors every alive node whose label is in `labels`.
std::int64_t fix_nodes_with_labels(Lattice& lattice, const std::vector<std::uint8_t>& labels);

}  // namespace tsf::crms
