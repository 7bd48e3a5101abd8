#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>

#include "tsf/segment/material_weight_quantization.h"

namespace tsf::segment {
namespace {

int sum_of(const std::array<std::uint8_t, 4>& w) {
  return w[0] + w[1] + w[2] + w[3];
}

TEST(MaterialWeightQuantization, AlwaysSumsTo255AndStaysWithinOneUnit) {
  std::mt19937 random(7);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  for (int trial = 0; trial < 20000; ++trial) {
    std::array<float, 4> f{u(random), u(random), u(random), u(random)};
    if (trial % 3 == 0) f[trial % 4] = 0.0f;
    const auto w = quantize_material_weights(f);
    ASSERT_EQ(sum_of(w), 255);
    const float total = f[0] + f[1] + f[2] + f[3];
    for (int c = 0; c < 4; ++c) EXPECT_LT(std::abs(w[c] - 255.0f * f[c] / total), 1.0f);
  }
}

TEST(MaterialWeightQuantization, OneHotIsExact) {
  EXPECT_EQ(quantize_material_weights({0, 0, 1, 0}), (std::array<std::uint8_t, 4>{0, 0, 255, 0}));
  EXPECT_EQ(quantize_material_weights({0.7f, 0, 0, 0.3f}),
            (std::array<std::uint8_t, 4>{179, 0, 0, 76}));
}

TEST(MaterialWeightQuantization, DegenerateInputFallsBackToChannelZero) {
  const std::array<std::uint8_t, 4> fallback{255, 0, 0, 0};
  EXPECT_EQ(quantize_material_weights({0, 0, 0, 0}), fallback);
  EXPECT_EQ(quantize_material_weights({-1, 0, 0, 0}), fallback);
  const float nan = std::numeric_limits<float>::quiet_NaN();
  EXPECT_EQ(quantize_material_weights({nan, nan, nan, nan}), fallback);
  EXPECT_EQ(sum_of(quantize_material_weights({nan, 0.5f, 0, 0})), 255);
}

}  // namespace
}  // namespace tsf::segment
