// The deformed CRMS lattice as the coupler and the collision code read it: rest geometry plus the
// solver's displacement arrays and alive flags, trivially copyable, host or device pointers.
//
//   dims        nodes along x, y, z
//   origin      float ×3, mm, rest position of node (0,0,0) (tissue space)
//   spacing     float ×3, mm, rest spacing hx, hy, hz
//   u[3]        #nodes floats each, displacement from rest, mm (crms::StateView)
//   flags       #nodes uint8 packed flags (crms::kAliveBit …); may be null: every node alive
//
// Every read is bounds-checked by the callers through in_range(); positions are formed relative
// to a cube's lower corner so float precision goes to the deformation, not to the tissue-space
// offset of a 250 mm head.
#pragma once

#include <cstdint>

#include "tsf/common/hd.h"
#include "tsf/common/vec3.h"
#include "tsf/crms/node_state_view.h"

namespace tsf::coupler {

struct DeformedLatticeView {
  Int3 dims;
  std::int64_t stride_y = 0;  ///< nx
  std::int64_t stride_z = 0;  ///< nx·ny
  float origin[3] = {0, 0, 0};
  float spacing[3] = {1, 1, 1};
  const float* u[3] = {nullptr, nullptr, nullptr};
  const std::uint8_t* flags = nullptr;

  TSF_HD_INLINE bool in_range(int i, int j, int k) const {
    return static_cast<unsigned>(i) < static_cast<unsigned>(dims.x) &&
           static_cast<unsigned>(j) < static_cast<unsigned>(dims.y) &&
           static_cast<unsigned>(k) < static_cast<unsigned>(dims.z);
  }
  TSF_HD_INLINE std::int64_t index(int i, int j, int k) const {
    return static_cast<std::int64_t>(i) + stride_y * j + stride_z * k;
  }
  TSF_HD_INLINE bool alive(std::int64_t n) const {
    return flags == nullptr || (flags[n] & crms::kAliveBit) != 0;
  }
  TSF_HD_INLINE Vec3f displacement(std::int64_t n) const { return {u[0][n], u[1][n], u[2][n]}; }
  /// Rest position of node (i,j,k), mm.
  TSF_HD_INLINE Vec3f rest(int i, int j, int k) const {
    return {origin[0] + static_cast<float>(i) * spacing[0],
            origin[1] + static_cast<float>(j) * spacing[1],
            origin[2] + static_cast<float>(k) * spacing[2]};
  }
};

}  // namespace tsf::coupler
