// The CRMS stencil: which nodes a node's force reads, and a bounds-safe accessor for kernels.
//
// Slots: 0 the node itself; 1..6 its face neighbours (slot 1+d for direction d); 7..18 the 12
// edge-diagonal nodes n + d1 + d2 (slot 7+t for angle t of angle_arms), read only with
// features::kSymmetricReactions. The force functions ask an accessor for u, v and flags of a
// slot; an accessor never reads outside the arrays (missing neighbours read the node itself, and
// the link bits make their contribution zero).
#pragma once

#include <cstdint>

#include "tsf/common/hd.h"
#include "tsf/common/vec3.h"
#include "tsf/crms/lattice_geometry.h"
#include "tsf/crms/node_state_view.h"

namespace tsf::crms {

constexpr int kStencilSlots = 19;
constexpr int kGatherStencilSlots = 7;

TSF_HD_INLINE constexpr int face_slot(int d) {
  return 1 + d;
}

/// Slot of n + d1 + d2 for two directions of different axes.
TSF_HD_INLINE constexpr int edge_slot(int d1, int d2) {
  const int lo = (d1 >> 1) < (d2 >> 1) ? d1 : d2;
  const int hi = (d1 >> 1) < (d2 >> 1) ? d2 : d1;
  const int plane = 3 - (lo >> 1) - (hi >> 1);
  return 7 + 4 * plane + 2 * (lo & 1) + (hi & 1);
}

/// Offset of a slot along one axis (−1, 0 or +1).
TSF_HD_INLINE constexpr int slot_offset(int slot, int axis) {
  if (slot == 0) return 0;
  if (slot <= 6) {
    const int d = slot - 1;
    return (d >> 1) == axis ? ((d & 1) ? 1 : -1) : 0;
  }
  const int t = slot - 7;
  const int plane = t >> 2;
  const int a = plane == 0 ? 1 : 0;
  const int b = plane == 2 ? 1 : 2;
  if (axis == a) return (t & 2) ? 1 : -1;
  if (axis == b) return (t & 1) ? 1 : -1;
  return 0;
}

/// Node read for `slot` of node n = (i,j,k): its index, or n itself outside the lattice.
TSF_HD_INLINE std::int64_t stencil_node(const LatticeView& lattice, std::int64_t n, int i, int j,
                                        int k, int slot) {
  const int dx = slot_offset(slot, 0), dy = slot_offset(slot, 1), dz = slot_offset(slot, 2);
  const bool inside = static_cast<unsigned>(i + dx) < static_cast<unsigned>(lattice.dims.x) &&
                      static_cast<unsigned>(j + dy) < static_cast<unsigned>(lattice.dims.y) &&
                      static_cast<unsigned>(k + dz) < static_cast<unsigned>(lattice.dims.z);
  return inside ? n + dx + dy * lattice.stride_y + dz * lattice.stride_z : n;
}

/// Accessor over global arrays by node index: the CUDA kernel's (one thread per node) and the
/// CPU loop's at row ends. Neighbours outside the lattice read the node itself.
struct IndexedStencil {
  using Scalar = float;
  LatticeView lattice;
  ConstStateView state;
  std::int64_t n;
  int i, j, k;

  TSF_HD_INLINE std::int64_t slot_index(int slot) const {
    return stencil_node(lattice, n, i, j, k, slot);
  }
  TSF_HD_INLINE Vec3f u(int slot) const {
    const std::int64_t m = slot_index(slot);
    return {state.u[0][m], state.u[1][m], state.u[2][m]};
  }
  TSF_HD_INLINE Vec3f v(int slot) const {
    const std::int64_t m = slot_index(slot);
    return {state.v[0][m], state.v[1][m], state.v[2][m]};
  }
  TSF_HD_INLINE unsigned flags(int slot) const { return lattice.flags[slot_index(slot)]; }
  TSF_HD_INLINE MaterialBlend material(int slot) const {
    return node_material(lattice, slot_index(slot));
  }
  TSF_HD_INLINE float inv_mass() const { return lattice.inv_mass[n]; }
  TSF_HD_INLINE Vec3f external_force() const {
    return {lattice.external_force[0][n], lattice.external_force[1][n],
            lattice.external_force[2][n]};
  }
};

}  // namespace tsf::crms
