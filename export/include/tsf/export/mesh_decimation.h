// Decimation to a triangle budget or a geometric error, with tissue borders kept (`tsf export
// --decimate N`, `--max-error MM`, `--lods`), by meshoptimizer's edge-collapse simplifier
// (Debian libmeshoptimizer-dev; quadric error metric, collapses onto existing vertices only, so
// every output vertex is an input vertex with its label, normal source and later positions).
//
// Tissue borders: before simplifying, every vertex on a border between tissues (triangle
// labels, imt::triangle_label) is split into one copy per tissue, so each tissue is its own
// region whose border meshoptimizer sees as a seam: a seam vertex collapses only along the seam
// (both copies together), and a vertex where three or more tissues meet stays. Each output
// triangle keeps its tissue and each output vertex takes the tissue of its copy: the per-tissue
// parts and colours of the full surface survive, with a crisp border.
//
// Speed: meshoptimizer is single-threaded. A large mesh (≥ 2 M triangles, more than one thread)
// is cut into slabs along its longest axis by triangle centroid; each slab is simplified on its
// own thread with its cut edges locked (meshopt_SimplifyLockBorder) to its share of the budget,
// then the stitched result is simplified once more, unlocked, to the budget (the slabs' cut
// lines are simplified there). bench/export (bench_decimate) measures this against one
// unsplit meshoptimizer call.
//
// What meshoptimizer 0.18 does not do, done here:
//   * locking: it has no per-vertex lock, but never moves a vertex with three or more copies at
//     its position, counted over the whole vertex buffer, so a locked vertex gets two unused
//     copies appended. Closed pieces too small for their share of the budget (under 48
//     triangles) are locked whole: squashed, they would vanish from the result.
//   * manifoldness: it has no link-condition check, so a collapse can make an edge of four
//     triangles. With manifold_runs > 1, where the result has one, the source vertices there and
//     their neighbours are locked and the decimation runs again; what is left is counted.
//   * clean triangles: folded pairs (fins) and duplicates are dropped and collinear triangles
//     flipped away (mesh_cleanup.h).
//   * a measured error bound: its estimate is a quadric sum, not a distance, and thin features
//     (a bony plate, a small spur) can lie several times max_error from the result. With
//     max_error_mm set, every input vertex farther than it from the result (exact distance,
//     surface_deviation.h) is locked and the decimation runs again (at most error_runs runs):
//     kept vertices lie on the result, so the bound holds for them, and the budget goes to the
//     rest.
//
// Error: meshoptimizer's own estimate (`meshopt_error_mm`) is a quadric bound, not a distance;
// the distance to the full surface is measured by surface_deviation.h.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "tsf/common/vec3.h"
#include "tsf/imt/surface_mesh.h"

namespace tsf::exporter {

struct DecimationOptions {
  std::size_t target_triangles = 0;  ///< stop at this many triangles (0: no count target)
  /// The largest distance allowed (0: none): meshoptimizer stops before its estimate exceeds it,
  /// and input vertices measured farther than it from the result are kept in a further run (at
  /// most error_runs runs; see the top).
  double max_error_mm = 0.0;
  int error_runs = 4;
  bool keep_tissue_borders = true;  ///< split vertices per tissue (see the top of this file)
  double mm_per_unit = 1.0;         ///< millimetres per coordinate unit of the mesh (metres: 1000)
  int threads = 0;                  ///< 0: OpenMP's default; 1: one unsplit meshoptimizer call
  std::size_t parallel_min_triangles = 2'000'000;  ///< smaller meshes are never split
  /// meshoptimizer runs at most: a further run locks the spots where the last one left an edge
  /// of more than two triangles (see the top). 1: one run, whatever is left is counted.
  int manifold_runs = 1;
  /// Source vertices that must not move, with their neighbours (callers that check the result
  /// their own way, as tissue bodies do, rerun with the spots they found).
  std::vector<std::uint32_t> locked_sources;

  /// Throws tsf::Error naming the field when neither target is set or one is out of range.
  void validate() const;
};

/// A decimated mesh as a map from its input: positions of any state of the input's topology
/// come through `origin`.
struct DecimatedMesh {
  std::vector<std::uint32_t> origin;  ///< output vertex -> input vertex
  std::vector<std::uint8_t> labels;   ///< per output vertex
  std::vector<std::uint32_t> part;    ///< per output vertex: the part of its copy (decimate_parts)
  std::vector<std::array<std::uint32_t, 3>> triangles;  ///< output vertex indices
  double meshopt_error_mm = 0.0;  ///< meshoptimizer's error estimate (largest over passes)
  double seconds = 0.0;
  /// CPU time on the critical path: this thread's, with the longest slab in place of the one it
  /// ran (thread CPU clocks): the wall time on an idle machine with a core per slab.
  double critical_path_cpu_s = 0.0;
  int slabs = 1;                 ///< 1 when simplified in one call
  std::size_t fins_removed = 0;  ///< folded or duplicate triangles meshoptimizer left, dropped
  std::size_t caps_flipped = 0, caps_removed = 0;  ///< collinear triangles it left (flip_caps)
  std::size_t locked_vertices = 0;       ///< kept in place: small pieces, non-manifold repairs
  std::size_t error_locked = 0;          ///< input vertices kept for the measured error bound
  int rounds = 1;                        ///< meshoptimizer runs (a rerun locks non-manifold spots)
  std::size_t nonmanifold_vertices = 0;  ///< on edges of more than two triangles, left
  bool one_surface = true;               ///< the parts are regions of one surface (decimate_parts)
};

/// Decimates `mesh` (any frame, mm_per_unit says its unit; welded, e.g. by clean_topology).
DecimatedMesh decimate(const imt::SurfaceMesh& mesh, const DecimationOptions& options);

/// Decimates a mesh cut into parts (`triangle_part`, any numbers): every vertex on a border
/// between parts is split into a copy per part, as tissue borders are above; vertices where
/// three or more parts meet never move. `labels` of the result are the parts' low 8 bits.
/// `one_surface`: the parts are regions of one surface (tissues); false: each part is a surface
/// of its own (the interfaces of tissue bodies), so triangles of two parts may coincide.
DecimatedMesh decimate_parts(const std::vector<Vec3f>& positions,
                             const std::vector<std::array<std::uint32_t, 3>>& triangles,
                             const std::vector<std::uint32_t>& triangle_part,
                             const DecimationOptions& options, bool one_surface = true);

/// A further level from an already decimated one (LOD chains): `level` maps into `mesh` like
/// decimate()'s result and so does the returned level.
DecimatedMesh decimate_further(const imt::SurfaceMesh& mesh, const DecimatedMesh& level,
                               const DecimationOptions& options);

/// The decimated mesh with positions taken from `mesh` and area-weighted normals shared by the
/// copies of one input vertex.
imt::SurfaceMesh decimated_surface(const imt::SurfaceMesh& mesh, const DecimatedMesh& d);

}  // namespace tsf::exporter
