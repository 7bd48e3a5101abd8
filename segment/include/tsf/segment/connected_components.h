// Connected components of a binary mask (6- or 26-neighbourhood), by flood fill.
//
// Used for the body's largest component and for bone hysteresis.
// (itk::ConnectedComponentImageFilter does the same, but its scanline set-up does pointer
// arithmetic on a null buffer, which UBSan rejects; the sanitizer build runs these paths.)
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

namespace tsf::segment {

struct ComponentLabels {
  std::vector<std::uint32_t> labels;  ///< per voxel: 0 = background, else 1..count
  std::vector<std::size_t> sizes;     ///< voxels per component; sizes[0] is unused (0)
  std::size_t count() const { return sizes.empty() ? 0 : sizes.size() - 1; }
  /// The label of the largest component (0 when there is none).
  std::uint32_t largest() const;
};

/// Components of the non-zero voxels of `mask` (dims[0]·dims[1]·dims[2] values, x fastest),
/// numbered in scan order. `full_connectivity`: 26 neighbours, else 6.
ComponentLabels label_connected_components(const unsigned char* mask,
                                           const std::array<std::size_t, 3>& dims,
                                           bool full_connectivity);

}  // namespace tsf::segment
