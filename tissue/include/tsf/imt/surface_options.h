// Options of IMT surfacing (full and incremental). Each optimisation step can be switched off.
#pragma once

#include <string>

namespace tsf::imt {

struct SurfaceOptions {
  /// Density iso-level in (0, 1]: inside is density >= iso; samples outside the volume read 0.
  float iso = 0.5f;
  /// Near-coincident vertex merging. A lattice point whose nearest iso-crossing on any of its 14
  /// lattice edges lies within snap_epsilon × edge length of it is moved onto the iso-level, so
  /// the vertices around it merge into one and the sliver triangles between them drop out. 0 turns
  /// merging off. Points snap only where the surface near them stays a disc (their inside and
  /// outside neighbours are each connected) and never two neighbours at once (the smaller
  /// fraction wins), so the mesh stays a closed 2-manifold; the decision depends on the volume
  /// alone, so incremental and full surfacing agree exactly. Shifts the surface by at most
  /// snap_epsilon × edge (edges are 1 voxel or √3/2 voxel long). Range [0, 0.5).
  float snap_epsilon = 0.1f;

  /// Throws tsf::Error naming the field when out of range.
  void validate() const;
};

}  // namespace tsf::imt
