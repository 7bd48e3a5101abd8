// The haptic device interface: a pose in, a force out, once per haptic tick.
//
// Everything device-specific stays behind this: a driver for OpenHaptics (hdGetDoublev
// HD_CURRENT_TRANSFORM / hdSetDoublev HD_CURRENT_FORCE inside its scheduler callback), CHAI3D
// (cGenericHapticDevice::getPosition / setForce) or libnifalcon implements read() and
// apply_force(), mapping its workspace to tissue space (mm) and µN to its own units; the force
// models and the loop never change. Calls come from the haptic thread only.
//
// Implementations here: ScriptedDevice (scripted_device.h, trajectories for tests and
// `tsf haptics`) and InputDevice (input_device.h, mouse and keyboard for the viewer).
#pragma once

#include <limits>

#include "tsf/common/vec3.h"
#include "tsf/volume/tool_shapes.h"

namespace tsf::haptics {

struct DeviceState {
  ToolPose pose;         ///< stylus pose in the deformed world, mm
  bool pressing = true;  ///< the stylus acts on the tissue (a button, or the script's mode)
  bool valid = true;     ///< false once a scripted device has run out of path
};

class HapticDevice {
 public:
  virtual ~HapticDevice() = default;
  /// The stylus pose now (haptic thread).
  virtual DeviceState read() = 0;
  /// The force to render, µN, deformed world (haptic thread).
  virtual void apply_force(const Vec3d& force_un) = 0;
  /// Largest force the device renders, µN (the loop clamps to it).
  virtual double max_force_un() const { return std::numeric_limits<double>::infinity(); }
};

}  // namespace tsf::haptics
