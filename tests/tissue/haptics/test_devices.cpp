// The devices behind HapticDevice: the scripted one follows its trajectory in simulated time, the
// mouse/keyboard one turns held keys and drags into stylus motion and hands the force back.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <thread>

#include "tsf/haptics/haptic_trajectory.h"
#include "tsf/haptics/input_device.h"
#include "tsf/haptics/scripted_device.h"

namespace tsf::haptics {
namespace {

TEST(ScriptedDevice, FollowsItsTrajectoryInSimulatedTime) {
  ScriptedDevice device(straight_pass({0, 0, 0}, {10, 0, 0}, 20.0, interaction::ToolMode::kPress));
  device.set_time(0.25);  // half way at 20 mm/s
  const DeviceState s = device.read();
  EXPECT_NEAR(s.pose.position.x, 5.0, 1e-9);
  EXPECT_TRUE(s.pressing);
  EXPECT_TRUE(s.valid);
  device.set_time(1.0);
  EXPECT_FALSE(device.read().valid) << "past the last keyframe the script has run out";
  device.apply_force({1, 2, 3});
  EXPECT_EQ(device.last_force().y, 2.0);
}

TEST(InputDevice, DragsMoveInTheViewPlaneAndKeysMoveAtTheirSpeed) {
  InputDeviceOptions o;
  o.home_mm = {10, 10, 10};
  o.speed_mm_s = 20.0;
  o.mm_per_pixel = 0.1;
  InputDevice device(o);
  device.set_view_axes({1, 0, 0}, {0, 0, 1}, {0, 1, 0});
  EXPECT_EQ(device.read().pose.position, (Vec3d{10, 10, 10}));
  device.drag(20, -10);  // right 2 mm, up 1 mm (screen y grows downwards)
  const Vec3d dragged = device.read().pose.position;
  EXPECT_NEAR(dragged.x, 12.0, 1e-12);
  EXPECT_NEAR(dragged.z, 11.0, 1e-12);
  EXPECT_NEAR(dragged.y, 10.0, 1e-12);

  // Hold "forward" for ~100 ms, reading every 5 ms like a (slow) haptic loop: ~2 mm along +y.
  device.key(2, +1, true);
  const auto t0 = std::chrono::steady_clock::now();
  while (std::chrono::steady_clock::now() - t0 < std::chrono::milliseconds(100)) {
    device.read();
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  device.key(2, +1, false);
  const double elapsed =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const Vec3d moved = device.read().pose.position - dragged;
  EXPECT_GT(moved.y, 0.5 * 20.0 * 0.1) << "moved " << moved.y << " mm in " << elapsed << " s";
  EXPECT_LE(moved.y, 20.0 * (elapsed + 0.01)) << "never faster than the key speed";
  EXPECT_NEAR(moved.x, 0.0, 1e-12);
  EXPECT_NEAR(moved.z, 0.0, 1e-12);

  device.apply_force({0, 0, 5});
  EXPECT_EQ(device.last_force().z, 5.0);
  device.set_pressing(false);
  EXPECT_FALSE(device.read().pressing);
  device.reset();
  EXPECT_EQ(device.read().pose.position, (Vec3d{10, 10, 10}));
}

}  // namespace
}  // namespace tsf::haptics
