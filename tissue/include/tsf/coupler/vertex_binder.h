// Binding render vertices to lattice cubes (host side, from rest-space geometry and the lattice's
// topology): the cube, local coordinates and the source nodes that may position the vertex.
//
// Which nodes belong with a vertex matters once the lattice is cut: a cube straddling a cut has
// corners on both pieces, and a vertex on one piece's cut face must follow that piece only. The
// binder groups the cube's 32 source nodes (cube_corners.h: 8 corners + 24 outside neighbours)
// into pieces connected by intact springs (Lattice::link) and keeps the piece of the vertex's
// anchor: the alive source that lies most behind the surface at the vertex,
//   score = (r − p)·n̂ / h + ¼·|r − p| / h   (smallest wins; n̂ the outward rest normal),
// so a vertex on a cut face, whose normal points across the gap, anchors on its own side. The
// cube's corners are scored first and win when the best lies behind the surface ((r − p)·n̂ < 0);
// the outside neighbours are scored only otherwise. A cube whose alive sources form one piece
// (no cut through it: the common case) needs no anchor.
//
// A cube without any alive source (thin tissue whose cells all fell below the deletion
// threshold) borrows the nearest cube that has one within kFallbackSearchNodes nodes; its local
// coordinates then extrapolate. A vertex with no alive node that near is an orphan: it keeps its
// rest position and is counted (VertexBinder::orphans()).
#pragma once

#include <cstdint>

#include "tsf/common/vec3.h"
#include "tsf/coupler/couple_vertex.h"
#include "tsf/crms/lattice.h"

namespace tsf::coupler {

struct BindingResult {
  VertexBinding binding;
  std::uint32_t sources = 0;  ///< cube_corners.h bit layout
  bool orphan = false;        ///< no alive node near: the vertex stays at rest
  bool borrowed = false;      ///< bound to a nearby cube, not the one holding the point
  bool single_piece = false;  ///< the cube's alive sources are all connected (sources = alive)
};

/// The rest position (mm) that (cell, w) stands for, in double precision.
Vec3d binding_rest_position(const crms::LatticeGeometry& geometry, const VertexBinding& binding);

class VertexBinder {
 public:
  static constexpr int kFallbackSearchNodes = 3;

  /// Keeps a reference: the lattice must outlive the binder and not change during a batch.
  explicit VertexBinder(const crms::Lattice& lattice);

  /// Binds a vertex at rest position p (mm) with outward unit normal n (zero: no preference).
  /// Consecutive calls for vertices of the same cube reuse the cube's piece grouping (bind
  /// vertices sorted by cube for speed).
  BindingResult bind(const Vec3f& rest_position, const Vec3f& rest_normal);

  /// Source pieces of a cube: bit b of the result is set for the sources connected to source
  /// `anchor_bit` (alive ones only). For the inverse map and tests.
  std::uint32_t connected_sources(const Int3& cell, int anchor_bit);
  /// Alive sources of a cube (bit layout of cube_corners.h).
  std::uint32_t alive_sources(const Int3& cell);

  std::int64_t orphans() const { return orphans_; }
  std::int64_t borrowed() const { return borrowed_; }
  /// Invalidates the cached grouping (call after the lattice topology changed).
  void forget_cache() { cached_cell_ = -1; }

 private:
  void group_cube(const Int3& cell);
  int pick_anchor(const Int3& cell, const Vec3d& p, const Vec3d& n) const;
  bool find_fallback_cube(const Vec3d& p, Int3& cell) const;

  const crms::Lattice& lattice_;
  std::int64_t cached_cell_ = -1;
  std::uint32_t alive_ = 0;     ///< alive sources of the cached cube
  bool single_piece_ = true;    ///< the cached cube's alive sources are all connected
  std::int8_t piece_[32] = {};  ///< piece id per source bit (−1: missing)
  std::int64_t orphans_ = 0;
  std::int64_t borrowed_ = 0;
};

}  // namespace tsf::coupler
