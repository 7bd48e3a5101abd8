// Material blend weights as 4 × uint8 that sum to exactly 255.
//
// Largest-remainder rounding (Hamilton's method): floor each share of 255, then hand the units
// still missing to the channels with the largest fractional parts. The result is the closest
// integer vector with the exact sum (no channel is off by a full unit or more).
#pragma once

#include <array>
#include <cmath>
#include <cstdint>

namespace tsf::segment {

/// `fractions` are non-negative and not all zero (they are normalised here). All zero (or not
/// finite) gives {255, 0, 0, 0}: channel 0 is the palette's default material.
inline std::array<std::uint8_t, 4> quantize_material_weights(
    const std::array<float, 4>& fractions) {
  float sum = 0.0f;
  for (float f : fractions) sum += (f > 0.0f && std::isfinite(f)) ? f : 0.0f;
  if (!(sum > 0.0f)) return {255, 0, 0, 0};
  std::array<std::uint8_t, 4> out{};
  std::array<float, 4> remainder{};
  int assigned = 0;
  for (int c = 0; c < 4; ++c) {
    const float f = (fractions[c] > 0.0f && std::isfinite(fractions[c])) ? fractions[c] : 0.0f;
    const float share = 255.0f * f / sum;
    const int whole = static_cast<int>(std::floor(share));
    out[c] = static_cast<std::uint8_t>(whole);
    remainder[c] = share - static_cast<float>(whole);
    assigned += whole;
  }
  for (int missing = 255 - assigned; missing > 0; --missing) {
    int best = 0;
    for (int c = 1; c < 4; ++c)
      if (remainder[c] > remainder[best]) best = c;
    ++out[best];
    remainder[best] = -1.0f;
  }
  return out;
}

}  // namespace tsf::segment
