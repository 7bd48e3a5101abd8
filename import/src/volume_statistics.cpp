#include "tsf/import/volume_statistics.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace tsf::import {

namespace {
/// Every float of magnitude 2^23 or more is a whole number.
constexpr float kAllIntegralAbove = 8388608.0f;
}  // namespace

VolumeStatistics volume_statistics(const float* values, std::size_t count) {
  float lo = std::numeric_limits<float>::infinity();
  float hi = -std::numeric_limits<float>::infinity();
  std::int64_t fractional = 0, non_finite = 0;
  std::int64_t first_bad = std::numeric_limits<std::int64_t>::max();
  const auto n = static_cast<std::int64_t>(count);
  // Chunks keep the inner loop branch-light (vectorisable min/max); non-finite values are rare
  // and located in a second, chunk-local pass.
  constexpr std::int64_t kChunk = 1 << 16;
  const std::int64_t chunks = (n + kChunk - 1) / kChunk;
#pragma omp parallel for schedule(static) reduction(min : lo, first_bad) reduction(max : hi) \
    reduction(+ : fractional, non_finite)
  for (std::int64_t c = 0; c < chunks; ++c) {
    const std::int64_t b = c * kChunk, e = std::min(n, b + kChunk);
    // Branch-free so the compiler vectorises it: (v − v) is NaN exactly for NaN/inf, and
    // (a + 2^23) − 2^23 is a rounded to a whole number for a < 2^23.
    float clo = lo, chi = hi;
    int cfrac = 0, cbad = 0;
#pragma omp simd reduction(min : clo) reduction(max : chi) reduction(+ : cfrac, cbad)
    for (std::int64_t i = b; i < e; ++i) {
      const float v = values[i];
      const float a = std::fabs(v);
      const float whole = (a + kAllIntegralAbove) - kAllIntegralAbove;
      cbad += (v - v) != 0.0f;
      cfrac += (a < kAllIntegralAbove) & (whole != a);
      clo = v < clo ? v : clo;
      chi = v > chi ? v : chi;
    }
    if (cbad) {
      clo = std::numeric_limits<float>::infinity();
      chi = -std::numeric_limits<float>::infinity();
      for (std::int64_t i = b; i < e; ++i) {
        const float v = values[i];
        if (!std::isfinite(v)) {
          first_bad = std::min(first_bad, i);
          continue;
        }
        clo = std::min(clo, v);
        chi = std::max(chi, v);
      }
    }
    lo = std::min(lo, clo);
    hi = std::max(hi, chi);
    fractional += cfrac;
    non_finite += cbad;
  }
  VolumeStatistics s;
  s.non_finite = non_finite;
  s.first_non_finite = non_finite ? first_bad : -1;
  s.integral = fractional == 0;
  if (lo <= hi) {
    s.min = lo;
    s.max = hi;
  }
  return s;
}

bool fits_int16(const VolumeStatistics& s) {
  return s.non_finite == 0 && s.integral && s.min >= -32768.0f && s.max <= 32767.0f;
}

void round_to_whole_numbers(float* values, std::size_t count) {
  const auto n = static_cast<std::int64_t>(count);
#pragma omp parallel for schedule(static)
  for (std::int64_t i = 0; i < n; ++i) {
    const float v = values[i];
    if (std::fabs(v) < kAllIntegralAbove)  // half away from zero; NaN and huge values unchanged
      values[i] = static_cast<float>(static_cast<std::int32_t>(v + (v < 0 ? -0.5f : 0.5f)));
  }
}

}  // namespace tsf::import
