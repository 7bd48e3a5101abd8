// Haptics driven by hostile numbers: a stylus far outside the tissue, a window too large for the
// voxel size, a trajectory too slow to play. Each is a tsf::Error saying what and why, never an
// integer overflow, a crash or a huge allocation. Runs under ASan + UBSan in CI (the suite name
// contains "Robustness").
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "haptics_test_helpers.h"
#include "support/error_of.h"
#include "tsf/common/error.h"

namespace tsf::haptics {
namespace {

using tsf::test::error_of;

TEST(HapticsRobustness, AStylusFarOutsideTheVolumeIsAnErrorNotAnOverflow) {
  const VoxelVolume volume = test::sphere_volume_of(5, 16, 0.5, 0.5);
  HapticFrame frame;
  for (const double far : {1e12, -1e12, 1e30}) {
    const std::string e = error_of([&] { capture_density(volume, {far, 0, 0}, 4.0, frame); });
    EXPECT_NE(e.find("outside the tissue volume"), std::string::npos) << far << ": " << e;
  }
  const double nan = std::numeric_limits<double>::quiet_NaN();
  EXPECT_NE(error_of([&] { capture_density(volume, {0, nan, 0}, 4.0, frame); }), "");
  // A stylus 1 m away is still a window of zeros (the check bounds indices, not distance).
  capture_density(volume, {1000, 0, 0}, 4.0, frame);
  ASSERT_FALSE(frame.density.empty());
  for (float d : frame.density) ASSERT_EQ(d, 0.0f);
  // Beside the sphere, the window holds tissue.
  capture_density(volume, test::volume_centre(volume), 4.0, frame);
  float peak = 0;
  for (float d : frame.density) peak = std::max(peak, d);
  EXPECT_EQ(peak, 1.0f);
}

TEST(HapticsRobustness, AWindowTooLargeForTheVoxelSizeIsRefusedBeforeAllocating) {
  const VoxelVolume volume = test::sphere_volume_of(5, 16, 0.5, 0.5);
  HapticFrame frame;
  const std::string e = error_of([&] { capture_density(volume, {0, 0, 0}, 1e4, frame); });
  EXPECT_NE(e.find("expected at most"), std::string::npos) << e;
  EXPECT_TRUE(frame.density.empty());
}

TEST(HapticsRobustness, APathTooSlowToPlayIsRefusedBeforeSizingTheSamples) {
  const interaction::Trajectory slow =
      straight_pass({0, 0, 0}, {10, 0, 0}, 1e-12, interaction::ToolMode::kIdle);
  PlaybackOptions options;
  const std::string e = error_of([&] { playback_ticks(slow, options); });
  EXPECT_NE(e.find("ticks"), std::string::npos) << e;
  EXPECT_NE(e.find(std::to_string(kMaxPlaybackTicks)), std::string::npos) << e;
  // 10 mm at 100 mm/s at 1 kHz: 0.1 s, 101 ticks.
  const interaction::Trajectory fine =
      straight_pass({0, 0, 0}, {10, 0, 0}, 100, interaction::ToolMode::kIdle);
  EXPECT_EQ(playback_ticks(fine, options), 101);
}

}  // namespace
}  // namespace tsf::haptics
