// Broad phase over the deformed lattice (CPU): the lattice is tiled into blocks of
// kBlockNodes³ nodes and each block keeps the axis-aligned box of its alive nodes' deformed
// positions. A query box visits only the blocks it overlaps, among those whose rest range lies
// within the largest displacement of the box (so a query costs what is near it, not the
// lattice's size). The tiling is the lattice's own
// (fixed topology), so a refit is one pass over the nodes, with no sorting or hashing; it is
// needed only after the state changed (steps, constraints, topology edits).
#pragma once

#include <cstdint>
#include <vector>

#include "tsf/common/vec3.h"
#include "tsf/coupler/deformed_lattice_view.h"

namespace tsf::collision {

class DeformedNodeBlocks {
 public:
  static constexpr int kBlockNodes = 4;

  explicit DeformedNodeBlocks(const Int3& lattice_dims);

  /// Recomputes every block's box from `lattice` (host pointers). OpenMP over blocks.
  void refit(const coupler::DeformedLatticeView& lattice);
  /// A few nodes moved to `positions` (mm) without a step (tool constraints): their blocks' boxes
  /// grow to hold them (they stay valid, perhaps a little loose, until the next refit).
  void nodes_moved(const std::vector<std::int64_t>& nodes, const std::vector<Vec3d>& positions,
                   const coupler::DeformedLatticeView& lattice);
  /// Alive nodes whose deformed position lies in the closed box [lo, hi] (mm), ascending, with
  /// their displacements. Needs a refit after the last state change.
  void query(const coupler::DeformedLatticeView& lattice, const Vec3f& lo, const Vec3f& hi,
             std::vector<std::int64_t>& nodes, std::vector<Vec3f>& displacements) const;

  /// Blocks whose box overlapped the last query (for the collision-cost benchmark).
  std::size_t last_blocks_visited() const { return last_visited_; }
  std::size_t block_count() const { return boxes_.size(); }

 private:
  struct Box {
    Vec3f lo, hi;
    bool empty = true;
  };
  Int3 dims_, blocks_;
  std::vector<Box> boxes_;
  float max_displacement_ = 0.0f;  ///< largest |u| of an alive node at the last refit, mm
  mutable std::size_t last_visited_ = 0;
};

}  // namespace tsf::collision
