// A device that replays a scripted stylus trajectory (thesis §8.6: software drives the stylus, so
// a haptic algorithm is measured without hand or device). Time is the loop's clock from start()
// (real time) or what set_time() says (playback in simulated time).
#pragma once

#include <atomic>
#include <chrono>

#include "tsf/haptics/haptic_device.h"
#include "tsf/haptics/seqlock.h"
#include "tsf/interaction/trajectory.h"

namespace tsf::haptics {

class ScriptedDevice final : public HapticDevice {
 public:
  explicit ScriptedDevice(interaction::Trajectory trajectory);
  /// Follows the wall clock from now.
  void start_clock();
  /// Follows simulated time instead (playback, offscreen frames): the next read() samples at
  /// `time_s` (any thread).
  void set_time(double time_s);
  DeviceState read() override;
  void apply_force(const Vec3d& force_un) override { last_force_.store(force_un); }
  PoseFrame frame() const override { return PoseFrame::kTissue; }
  std::string describe() const override { return "scripted"; }
  /// A live loop plays the path in wall-clock time from its start.
  void on_loop_start() override { start_clock(); }
  Vec3d last_force() const { return last_force_.load(); }
  const interaction::Trajectory& trajectory() const { return trajectory_; }

 private:
  interaction::Trajectory trajectory_;
  std::atomic<bool> wall_clock_{false};
  std::chrono::steady_clock::time_point start_;
  std::atomic<double> time_s_{0};  ///< set_time() may come from another thread than read()
  Seqlock<Vec3d> last_force_;
};

}  // namespace tsf::haptics
