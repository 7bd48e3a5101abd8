// Clean triangles for export: no zero-area and no duplicate triangles, the surface kept closed.
//
// A surface from IMT can hold vertices at one position under different lattice keys (a lattice
// point whose value is exactly the iso-level: docs/imt.md) and hence triangles with no area.
// clean_topology() turns a mesh into one without them, changing no position:
//   1. weld: vertices at exactly the same position become one (the lowest index keeps its
//      label); for a sequence only where they coincide, within a tolerance, in every state;
//   2. triangles that repeat a vertex after welding are dropped (their edges pair up across the
//      welded vertex, so a closed surface stays closed);
//   3. duplicates (the same three vertices): same-orientation copies are dropped, keeping one;
//      an oppositely oriented pair (a zero-volume fin) is dropped whole;
//   4. zero-area triangles with three distinct, collinear corners ("caps", the middle corner c on
//      the longest edge ab): the neighbour across ab, (b, a, d), becomes (b, c, d) + (c, a, d)
//      and the cap goes: the edge flip that keeps every edge paired and the surface unchanged.
//      A cap without exactly one neighbour there is dropped (counted).
// Zero area is imt::measure_quality's test (twice the area ≤ 1e-12 × longest edge², which
// includes repeated corners); a duplicate has the same three corner positions as an earlier
// triangle, either orientation. Vertices no triangle uses any more are dropped.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "tsf/common/vec3.h"
#include "tsf/imt/surface_mesh.h"

namespace tsf::exporter {

struct TriangleDefects {
  std::size_t triangles = 0;
  std::size_t zero_area = 0;  ///< twice the area ≤ 1e-12 × longest edge² (or a repeated corner)
  std::size_t duplicates = 0;  ///< same corner positions as an earlier triangle
};

/// Whether the triangle (a, b, c) has zero area: twice its area ≤ 1e-12 × its longest edge²
/// (imt::measure_quality's test; a repeated corner counts).
bool zero_area_triangle(const Vec3f& a, const Vec3f& b, const Vec3f& c);

/// Counts zero-area and duplicate triangles of `mesh` (positions, any frame).
TriangleDefects count_triangle_defects(const imt::SurfaceMesh& mesh);

struct CleanupReport {
  TriangleDefects before, after;
  std::size_t welded_vertices = 0;     ///< vertices merged into another at the same position
  std::size_t collapsed_removed = 0;   ///< triangles repeating a vertex after welding
  std::size_t duplicates_removed = 0;  ///< same-orientation copies dropped
  std::size_t fins_removed = 0;        ///< triangles of oppositely oriented duplicate pairs
  std::size_t caps_flipped = 0;        ///< collinear triangles removed by an edge flip
  std::size_t caps_removed = 0;        ///< collinear triangles dropped (no single neighbour)
};

/// A cleaned mesh as a map from the input: positions (and any state of the same topology) come
/// through `origin`.
struct CleanTopology {
  std::vector<std::uint32_t> origin;  ///< output vertex -> input vertex (its weld group's lowest)
  std::vector<std::uint8_t> labels;   ///< per output vertex
  std::vector<std::array<std::uint32_t, 3>> triangles;  ///< output vertex indices
  CleanupReport report;

  std::size_t vertex_count() const { return origin.size(); }
};

/// Cleans `mesh` (see the top of this file). `other_states`: the positions of further states
/// with the same topology (a sequence's morph targets), each as many as mesh's; vertices weld
/// only where every state has them within `tolerance` of each other, and a cap is judged in the
/// first state. report.after is counted in `mesh`'s positions.
CleanTopology clean_topology(const imt::SurfaceMesh& mesh,
                             const std::vector<const std::vector<Vec3f>*>& other_states = {},
                             float tolerance = 1e-3f);

struct DuplicateRemoval {
  std::size_t duplicates = 0;  ///< same-orientation copies dropped
  std::size_t fins = 0;        ///< triangles of oppositely oriented pairs dropped
};
/// Step 3 above on its own: triangles with the same three vertices (compared through
/// `key_of_vertex`, e.g. the source vertex of copies; empty: the indices themselves) keep one
/// copy of the orientation in excess, none when the orientations cancel.
DuplicateRemoval drop_duplicate_triangles(std::vector<std::array<std::uint32_t, 3>>& triangles,
                                          const std::vector<std::uint32_t>& key_of_vertex = {});

struct CapRemoval {
  std::size_t flipped = 0;  ///< caps removed by flipping their long edge into the neighbour
  std::size_t removed = 0;  ///< caps dropped (no single neighbour across the long edge)
};
/// Step 4 above on its own: zero-area triangles with three distinct corners, in `positions`.
CapRemoval flip_caps(std::vector<std::array<std::uint32_t, 3>>& triangles,
                     const std::vector<Vec3f>& positions);

/// `positions` gathered through `origin` (any state of the input's topology).
std::vector<Vec3f> gather(const std::vector<Vec3f>& positions,
                          const std::vector<std::uint32_t>& origin);

}  // namespace tsf::exporter
