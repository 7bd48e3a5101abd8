// Tearing through every layer (docs/effects.md, "Tearing through every layer"): what a spring torn
// by the solver (crms effects: tearing, node masking) does to the voxels (R1), so the surface (R2)
// opens where the lattice (R3) tore and the coupler re-binds each side to its own piece.
//
// Node n of a voxel-built lattice (spacing k voxels) owns the k³ voxels [n·k, (n+1)·k) per axis
// (lattice_builders.h). A torn spring n → n+axis separates the voxels between its nodes like a
// thin cut through the face the two cells share: the two voxel layers either side of that face,
// (c+1)·k − 1 and (c+1)·k along the axis (two, as a blade is at least two voxels wide: one layer
// leaves IMT's body centres at the iso-level and the surface reconnects), across it the k × k
// columns of n's cell — grown into each neighbouring column of cells that holds no spring
// parallel to the torn one (a dead cell's thin skin of tissue, the air beside the tissue), so
// that no sliver of voxels bridges the tear. At one voxel per node the two layers are the two
// cells: those nodes go (the thesis's tearing removes the nodes along the tear).
//
// A node that tearing leaves without any spring (node masking takes all of a node's springs at
// once; a node can also lose its last one) is "masked": its whole cell is cleared, so the
// occupancy test of lattice_topology_edit.h deletes it, as the thesis's node masking removes the
// nodes along the tear rather than splitting them.
#pragma once

#include <cstdint>
#include <vector>

#include "tsf/common/vec3.h"
#include "tsf/crms/lattice.h"
#include "tsf/crms/solver.h"
#include "tsf/volume/voxel_box.h"

namespace tsf::interaction {

struct TornVoxels {
  std::vector<VoxelBox> boxes;             ///< voxels to clear (clipped to the volume)
  std::vector<std::int64_t> masked_nodes;  ///< alive nodes left without a spring, ascending
  VoxelBox bounds{};                       ///< bounding box of `boxes`
};

/// The voxels that `torn` springs (from their lower node, + direction; the host lattice already
/// without them) separate, in a volume of `volume_dims` voxels at `node_spacing_voxels` per node.
TornVoxels torn_voxels(const crms::Lattice& lattice, const std::vector<crms::SpringRef>& torn,
                       int node_spacing_voxels, const Int3& volume_dims);

}  // namespace tsf::interaction
