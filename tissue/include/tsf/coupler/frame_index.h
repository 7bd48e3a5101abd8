// The coupler's index of frames: frame id by key (cube cell, sources).
#pragma once

#include <cstdint>

#include "tsf/common/open_hash_map.h"

namespace tsf::coupler {

using FrameIndex = OpenHashMap<std::uint32_t>;

/// A frame's key in the index: its cube cell in the high 32 bits, its sources in the low ones.
inline std::uint64_t frame_key(std::int32_t cell, std::uint32_t sources) {
  return (static_cast<std::uint64_t>(static_cast<std::uint32_t>(cell)) << 32) | sources;
}

}  // namespace tsf::coupler
