// The haptic device interface: a pose in, a force out, once per haptic tick.
//
// Everything device-specific stays behind this: a driver for OpenHaptics (hdGetDoublev
// HD_CURRENT_TRANSFORM / hdSetDoublev HD_CURRENT_FORCE inside its scheduler callback), CHAI3D
// (cGenericHapticDevice::getPosition / setForce), libnifalcon or a network link (an OpenIGTLink
// TRANSFORM of the tool pose in, the force out) implements read() and apply_force(), mapping its
// workspace to millimetres and µN to its own units; the force models and the loop never change.
// read() and apply_force() are called from the haptic thread only.
//
// Frames: a device says which frame it speaks (frame()): patient LPS mm by default, what a device
// registered to the patient reports; the loop turns its poses into tissue space and its forces
// back into the patient frame (device_frame.h). The devices inside tsf (the viewer's mouse and
// keyboard, scripted trajectories) speak tissue space.
//
// Devices are picked by name (device_registry.h: `--device scripted`, `--device mouse`, and the
// drivers that register themselves there).
#pragma once

#include <limits>
#include <string>

#include "tsf/common/vec3.h"
#include "tsf/haptics/device_frame.h"
#include "tsf/volume/tool_shapes.h"

namespace tsf::haptics {

struct DeviceState {
  ToolPose pose;         ///< stylus pose, mm, in the device's frame (the loop: tissue space)
  bool pressing = true;  ///< the stylus acts on the tissue (a button, or the script's mode)
  bool valid = true;     ///< false once a scripted device has run out of path, or a link is down
};

class HapticDevice {
 public:
  virtual ~HapticDevice() = default;
  /// The stylus pose now (haptic thread).
  virtual DeviceState read() = 0;
  /// The force to render, µN, in the device's frame (haptic thread).
  virtual void apply_force(const Vec3d& force_un) = 0;
  /// Largest force the device renders, µN (the loop clamps to it).
  virtual double max_force_un() const { return std::numeric_limits<double>::infinity(); }
  /// The frame of read()'s poses and apply_force()'s forces.
  virtual PoseFrame frame() const { return PoseFrame::kPatient; }
  /// What it is, for reports ("scripted", "mouse", a driver's name and address).
  virtual std::string describe() const { return "device"; }
  /// The loop is about to start ticking in wall-clock time (HapticLoop::start, on the caller's
  /// thread): a scripted path starts its clock, a driver may connect. Not called for ticks taken
  /// one at a time (HapticLoop::tick_now).
  virtual void on_loop_start() {}
};

}  // namespace tsf::haptics
