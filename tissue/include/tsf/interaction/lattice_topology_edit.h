// From a voxel edit to the lattice: which nodes to delete and which springs to break
// (docs/design.md "Cutting, ablation, collisions"; thesis §7.2).
//
// Node n (voxel-built lattice, node spacing k voxels) owns the k³ voxels
// [n·k, (n+1)·k) per axis (lattice_builders.h). After an edit:
//   * deletion: an alive node whose cell occupancy (mean density of its k³ voxels, voxels beyond
//     the volume count as empty) dropped below `deletion_threshold` is deleted;
//   * spring cutting (finer than the thesis): the spring from n to its +axis neighbour spans the
//     "bridge" of voxels between the two node centres — along the axis from n's centre voxel to
//     the neighbour's, across it the k×k columns the two cells share. The spring carries tissue
//     while at least one column is solid (every voxel ≥ iso). It is broken when the edit took
//     that away: a solid column existed before the edit and none does after. Bridges that never
//     had a solid column (thin surface layers) are left alone, so an edit nearby does not
//     loosen tissue it did not cut.
// Only nodes and bridges overlapping the changed voxels are examined.
#pragma once

#include <cstdint>
#include <utility>
#include <vector>

#include "tsf/crms/lattice.h"
#include "tsf/crms/solver.h"
#include "tsf/volume/voxel_box.h"
#include "tsf/volume/voxel_volume.h"

namespace tsf::interaction {

/// Densities of a box of voxels copied before an edit (what the spring test compares against).
class DensitySnapshot {
 public:
  /// Copies `box` (clipped to the volume).
  void capture(const VoxelVolume& volume, const VoxelBox& box);
  const VoxelBox& box() const { return box_; }
  /// Density of voxel (i,j,k) before the edit: the copy inside the box, else the volume's.
  float before(const VoxelVolume& volume, int i, int j, int k) const {
    if (box_.contains(i, j, k))
      return density_[static_cast<std::size_t>(i - box_.lo.x) +
                      static_cast<std::size_t>(extent_.x) *
                          (static_cast<std::size_t>(j - box_.lo.y) +
                           static_cast<std::size_t>(extent_.y) *
                               static_cast<std::size_t>(k - box_.lo.z))];
    return volume.density(i, j, k);
  }
  /// Σ (before − now) × voxel volume over `changed` (⊆ box), mm³: the tissue an edit removed.
  double removed_volume_mm3(const VoxelVolume& volume, const VoxelBox& changed) const;
  /// The same, per tissue label of the voxels (labels that lost nothing are left out), ascending.
  std::vector<std::pair<std::uint8_t, double>> removed_by_label_mm3(const VoxelVolume& volume,
                                                                    const VoxelBox& changed) const;

 private:
  VoxelBox box_{};
  Int3 extent_{};
  std::vector<float> density_;
};

struct LatticeTopologyEdit {
  std::vector<std::int64_t> deleted_nodes;      ///< ascending
  std::vector<crms::SpringRef> broken_springs;  ///< each once, from its lower node (+ direction)
  bool empty() const { return deleted_nodes.empty() && broken_springs.empty(); }
};

/// The nodes and springs an edit of `changed` voxels takes out (see header). `volume` is after
/// the edit, `before` holds the densities from before it over (at least) `changed`.
LatticeTopologyEdit find_lattice_topology_edit(
    const VoxelVolume& volume, const DensitySnapshot& before, const VoxelBox& changed,
    const crms::Lattice& lattice, int node_spacing_voxels, float deletion_threshold, float iso);

/// Mean density of node n's cell (lattice_builders.h's occupancy).
float cell_occupancy(const VoxelVolume& volume, const crms::LatticeGeometry& geometry,
                     std::int64_t node, int node_spacing_voxels);

}  // namespace tsf::interaction
