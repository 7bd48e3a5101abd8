// A mouse-and-keyboard stylus for the viewer (no haptic hardware): the viewer's thread reports
// input, the haptic thread reads the resulting pose; the force comes back for display (an arrow).
//
//   viewer thread                         haptic thread
//   set_view_axes(right, up, forward)     read():  pose = home + ∫ key velocity dt + drag offset
//   key(axis, direction, down)            apply_force(F)
//   drag(dx_px, dy_px), move_by(mm)       viewer:  last_force() to draw
//   set_pressing(on), reset()
// Keys move the stylus at `speed_mm_s` along the view axes while held; a mouse drag moves it in
// the view plane by `mm_per_pixel`. Everything crosses threads through seqlocks: neither side
// waits.
#pragma once

#include <chrono>

#include "tsf/haptics/haptic_device.h"
#include "tsf/haptics/seqlock.h"

namespace tsf::haptics {

struct InputDeviceOptions {
  Vec3d home_mm{0, 0, 0};
  double speed_mm_s = 20.0;
  double mm_per_pixel = 0.05;
};

class InputDevice final : public HapticDevice {
 public:
  explicit InputDevice(const InputDeviceOptions& options = {});

  // ---- viewer thread ----
  /// Where the stylus starts (tissue space): before the loop starts only.
  void set_home(const Vec3d& home_mm) { options_.home_mm = home_mm; }
  /// Unit vectors of the view (screen right, screen up, into the screen), tissue space.
  void set_view_axes(const Vec3d& right, const Vec3d& up, const Vec3d& forward);
  /// axis 0 = right, 1 = up, 2 = forward; direction ±1; down = held.
  void key(int axis, int direction, bool down);
  void drag(double dx_pixels, double dy_pixels);
  void set_pressing(bool pressing);
  /// Back to home, keys released.
  void reset();
  Vec3d last_force() const { return force_.load(); }

  // ---- haptic thread ----
  DeviceState read() override;
  void apply_force(const Vec3d& force_un) override { force_.store(force_un); }
  PoseFrame frame() const override { return PoseFrame::kTissue; }
  std::string describe() const override { return "mouse and keyboard"; }
  /// Moves the stylus by `delta_mm` (tissue space) at once (viewer thread): the mouse pointing
  /// at a new place in the view plane.
  void move_by(const Vec3d& delta_mm);

 private:
  struct Input {
    Vec3d axes[3];
    int keys[3];           ///< −1, 0, +1 per axis
    Vec3d drag_offset_mm;  ///< accumulated drag, tissue space
    bool pressing;
    unsigned reset_count;
  };
  InputDeviceOptions options_;
  Input input_{};  ///< viewer thread's copy (it is the only writer)
  Seqlock<Input> shared_;
  Seqlock<Vec3d> force_;
  // Haptic thread's integration state.
  Vec3d key_offset_mm_{0, 0, 0};
  unsigned seen_reset_ = 0;
  bool started_ = false;
  std::chrono::steady_clock::time_point last_read_;
};

}  // namespace tsf::haptics
