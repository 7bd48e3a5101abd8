#include <gtest/gtest.h>

#include "tsf/segment/hu_density_ramp.h"

namespace tsf::segment {
namespace {

TEST(HuDensityRamp, IsOneHalfExactlyAtTheThreshold) {
  EXPECT_FLOAT_EQ(rising_density_ramp(-480.0f, -480.0f, 800.0f), 0.5f);
  EXPECT_FLOAT_EQ(falling_density_ramp(250.0f, 250.0f, 300.0f), 0.5f);
}

TEST(HuDensityRamp, IsLinearInsideTheRampAndClampedOutside) {
  // Linear: equal HU steps give equal density steps (what makes interpolated crossings exact).
  const float a = rising_density_ramp(-600.0f, -480.0f, 800.0f);
  const float b = rising_density_ramp(-500.0f, -480.0f, 800.0f);
  const float c = rising_density_ramp(-400.0f, -480.0f, 800.0f);
  EXPECT_NEAR(b - a, c - b, 1e-6f);
  EXPECT_NEAR(b - a, 100.0f / 800.0f, 1e-6f);
  EXPECT_EQ(rising_density_ramp(-1000.0f, -480.0f, 800.0f), 0.0f);
  EXPECT_EQ(rising_density_ramp(40.0f, -480.0f, 800.0f), 1.0f);
  EXPECT_EQ(falling_density_ramp(1500.0f, 250.0f, 300.0f), 0.0f);
  EXPECT_EQ(falling_density_ramp(0.0f, 250.0f, 300.0f), 1.0f);
}

TEST(HuDensityRamp, ZeroWidthIsAHardStep) {
  EXPECT_EQ(rising_density_ramp(-480.1f, -480.0f, 0.0f), 0.0f);
  EXPECT_EQ(rising_density_ramp(-480.0f, -480.0f, 0.0f), 1.0f);
  EXPECT_EQ(falling_density_ramp(249.9f, 250.0f, 0.0f), 1.0f);
  EXPECT_EQ(falling_density_ramp(250.0f, 250.0f, 0.0f), 0.0f);
}

TEST(HuDensityRamp, StaysInUnitIntervalForExtremeValues) {
  for (float hu : {-1e9f, -3024.0f, -1.0f, 0.0f, 3071.0f, 1e9f}) {
    const float d = rising_density_ramp(hu, -480.0f, 800.0f);
    EXPECT_GE(d, 0.0f);
    EXPECT_LE(d, 1.0f);
  }
}

}  // namespace
}  // namespace tsf::segment
