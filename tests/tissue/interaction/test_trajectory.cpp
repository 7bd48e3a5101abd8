// Scripted trajectories: keyframes interpolate, modes hold until the next keyframe, bad scripts
// are rejected naming the keyframe.
#include <gtest/gtest.h>

#include "tsf/common/error.h"
#include "tsf/interaction/trajectory.h"

namespace tsf::interaction {
namespace {

TEST(Trajectory, InterpolatesPosesAndHoldsModes) {
  const Rotation q = Rotation::about_axis({0, 0, 1}, 1.0);
  const Trajectory t({{0.1, {{0, 0, 0}, {}}, ToolMode::kPress},
                      {0.3, {{2, 4, 6}, q}, ToolMode::kAblate},
                      {0.5, {{2, 4, 0}, q}, ToolMode::kIdle}});
  EXPECT_FALSE(t.sample(0.0).started);
  EXPECT_EQ(t.sample(0.0).mode, ToolMode::kIdle);
  const TrajectorySample mid = t.sample(0.2);
  EXPECT_TRUE(mid.started);
  EXPECT_EQ(mid.mode, ToolMode::kPress);
  EXPECT_NEAR(mid.pose.position.x, 1.0, 1e-12);
  EXPECT_NEAR(mid.pose.position.z, 3.0, 1e-12);
  EXPECT_NEAR(Rotation{}.angle_to(mid.pose.orientation), 0.5, 1e-9);
  EXPECT_EQ(t.sample(0.4).mode, ToolMode::kAblate);
  EXPECT_EQ(t.sample(9.0).mode, ToolMode::kIdle);
  EXPECT_NEAR(t.sample(9.0).pose.position.z, 0.0, 1e-12);
}

TEST(Trajectory, RejectsTimesThatDoNotIncrease) {
  try {
    Trajectory({{0.2, {}, ToolMode::kPress}, {0.2, {}, ToolMode::kPress}});
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("keyframe 1"), std::string::npos) << e.what();
  }
  EXPECT_THROW(Trajectory({{0.0, {{0, 0, 0}, {0, 0, 0, 0}}, ToolMode::kPress}}), Error);
  EXPECT_THROW(tool_mode_from_string("slice"), Error);
  EXPECT_EQ(tool_mode_from_string("cut"), ToolMode::kCut);
}

}  // namespace
}  // namespace tsf::interaction
