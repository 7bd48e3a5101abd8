// The coupler's index of frames by key (cube cell in the high 32 bits, sources in the low ones)
// to frame id.
#pragma once

#include <cstdint>

#include "tsf/common/open_hash_map.h"

namespace tsf::coupler {

using FrameIndex = OpenHashMap<std::uint32_t>;

}  // namespace tsf::coupler
