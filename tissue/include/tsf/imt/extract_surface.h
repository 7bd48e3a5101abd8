// Full IMT surfacing of a voxel volume (docs/design.md, "The pipeline" (R2)): 12 tetrahedra per
// cube on the BCC lattice, vertices by linear interpolation on tetrahedron edges, welded exactly by
// lattice edge key.
//
// Multithreaded in the vtkFlyingEdges3D style, over blocks of 16³ cubes:
//   1. skip blocks whose density range (per-brick min/max, VoxelVolume::brick_ranges, recomputed
//      here when stale) cannot straddle the iso-level;
//   2. count: each active block classifies its lattice window and counts the vertices it owns
//      (a slot mask per cube) and the triangles it makes;
//   3. prefix sums give every block its output range; the arrays are allocated once;
//   4. write: each block writes its vertices and its triangles in place, resolving vertex keys
//      to indices arithmetically from the slot masks (no hashing, no locks);
//   5. area-weighted normals are summed in fixed point, each thread over a range of z slabs of
//      blocks (the ranges' insides first, then their first and last slabs: ranges that far apart
//      share no vertex), so the result is the same for any thread count.
// Small volumes run on the calling thread.
#pragma once

#include <cstddef>

#include "tsf/imt/surface_mesh.h"
#include "tsf/imt/surface_options.h"
#include "tsf/volume/voxel_volume.h"

namespace tsf::imt {

struct SurfaceBuildStats {
  double ranges_s = 0;    ///< brick density ranges (0 when the volume's were current)
  double mesh_s = 0;      ///< pass 2: meshing the active blocks
  double assemble_s = 0;  ///< passes 3-4: offsets, copies, index resolution
  double normals_s = 0;   ///< area-weighted normals
  double total_s = 0;
  std::size_t blocks = 0;         ///< blocks of 16³ cubes
  std::size_t active_blocks = 0;  ///< blocks whose range straddles the iso-level
  int threads = 1;
};

/// Surfaces `volume` at options.iso. Vertex positions are in tissue space (mm,
/// VolumeGeometry::index_to_tissue). With compute_normals false, mesh.normals stays empty.
/// Densities must be finite and in [0,1] (VoxelVolume::validate; readers and edits ensure it).
SurfaceMesh extract_surface(const VoxelVolume& volume, const SurfaceOptions& options = {},
                            SurfaceBuildStats* stats = nullptr, bool compute_normals = true);

}  // namespace tsf::imt
