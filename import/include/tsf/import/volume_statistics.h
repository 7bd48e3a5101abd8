// Value statistics of a voxel buffer, used to choose the stored pixel type (int16 when every
// value is a whole number that fits) and to check values are plausible.
#pragma once

#include <cstddef>
#include <cstdint>

namespace tsf::import {

struct VolumeStatistics {
  float min = 0, max = 0;              ///< over finite values
  bool integral = true;                ///< every finite value is a whole number
  std::int64_t non_finite = 0;         ///< NaN or infinite values
  std::int64_t first_non_finite = -1;  ///< index of the first one, -1 if none
};

/// One parallel pass over `count` values.
VolumeStatistics volume_statistics(const float* values, std::size_t count);

/// Rounds every value to the nearest whole number (halves away from zero), in parallel.
void round_to_whole_numbers(float* values, std::size_t count);

/// True when `s` allows int16 storage without loss: integral and within [-32768, 32767].
bool fits_int16(const VolumeStatistics& s);

}  // namespace tsf::import
