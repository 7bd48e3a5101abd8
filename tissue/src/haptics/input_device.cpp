#include "tsf/haptics/input_device.h"

#include <algorithm>

namespace tsf::haptics {

InputDevice::InputDevice(const InputDeviceOptions& options) : options_(options) {
  input_.axes[0] = {1, 0, 0};
  input_.axes[1] = {0, 0, 1};
  input_.axes[2] = {0, 1, 0};
  input_.keys[0] = input_.keys[1] = input_.keys[2] = 0;
  input_.drag_offset_mm = {0, 0, 0};
  input_.pressing = true;
  input_.reset_count = 0;
  shared_.store(input_);
}

void InputDevice::set_view_axes(const Vec3d& right, const Vec3d& up, const Vec3d& forward) {
  input_.axes[0] = normalized_or_zero(right);
  input_.axes[1] = normalized_or_zero(up);
  input_.axes[2] = normalized_or_zero(forward);
  shared_.store(input_);
}

void InputDevice::key(int axis, int direction, bool down) {
  if (axis < 0 || axis > 2) return;
  input_.keys[axis] = down ? (direction < 0 ? -1 : 1) : 0;
  shared_.store(input_);
}

void InputDevice::drag(double dx_pixels, double dy_pixels) {
  // Screen y grows downwards: dragging up moves the stylus along +up.
  input_.drag_offset_mm += input_.axes[0] * (dx_pixels * options_.mm_per_pixel) -
                           input_.axes[1] * (dy_pixels * options_.mm_per_pixel);
  shared_.store(input_);
}

void InputDevice::move_by(const Vec3d& delta_mm) {
  if (!all_finite(delta_mm)) return;
  input_.drag_offset_mm += delta_mm;
  shared_.store(input_);
}

void InputDevice::set_pressing(bool pressing) {
  input_.pressing = pressing;
  shared_.store(input_);
}

void InputDevice::reset() {
  input_.keys[0] = input_.keys[1] = input_.keys[2] = 0;
  input_.drag_offset_mm = {0, 0, 0};
  ++input_.reset_count;
  shared_.store(input_);
}

DeviceState InputDevice::read() {
  const Input in = shared_.load();
  const auto now = std::chrono::steady_clock::now();
  // Held keys move the stylus at constant speed; a stall longer than 50 ms (a paused thread) is
  // not turned into a jump.
  const double dt =
      started_ ? std::min(0.05, std::chrono::duration<double>(now - last_read_).count()) : 0.0;
  started_ = true;
  last_read_ = now;
  if (in.reset_count != seen_reset_) {
    seen_reset_ = in.reset_count;
    key_offset_mm_ = {0, 0, 0};
  }
  for (int a = 0; a < 3; ++a)
    key_offset_mm_ += in.axes[a] * (static_cast<double>(in.keys[a]) * options_.speed_mm_s * dt);
  DeviceState state;
  state.pose.position = options_.home_mm + key_offset_mm_ + in.drag_offset_mm;
  state.pressing = in.pressing;
  return state;
}

}  // namespace tsf::haptics
