#include "tsf/haptics/scripted_device.h"

#include "tsf/common/error.h"

namespace tsf::haptics {

ScriptedDevice::ScriptedDevice(interaction::Trajectory trajectory)
    : trajectory_(std::move(trajectory)), time_s_(trajectory_.start_time()) {
  require(!trajectory_.empty(), "scripted device: the trajectory has no keyframes");
}

void ScriptedDevice::start_clock() {
  wall_clock_ = true;
  start_ = std::chrono::steady_clock::now();
}

void ScriptedDevice::set_time(double time_s) {
  wall_clock_ = false;
  time_s_ = time_s;
}

DeviceState ScriptedDevice::read() {
  double t = time_s_;
  if (wall_clock_)
    t = trajectory_.start_time() +
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  const interaction::TrajectorySample s = trajectory_.sample(t);
  DeviceState state;
  state.pose = s.pose;
  state.pressing = s.started && s.mode == interaction::ToolMode::kPress;
  state.valid = t <= trajectory_.end_time();
  return state;
}

}  // namespace tsf::haptics
