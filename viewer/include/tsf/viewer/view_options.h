// What the viewer shows and how: window, camera, slice planes, overlays. Defaults suit both the
// interactive window and offscreen frames; a view script (view_script.h) can set each of them.
#pragma once

#include <cmath>
#include <functional>
#include <limits>
#include <string>

#include "tsf/common/vec3.h"

namespace tsf::viewer {

/// Where the patient's directions point in the tissue space the viewer draws (unit vectors).
/// The default camera looks at the face (from anterior, superior up), and the orientation cube
/// in the corner names each side. The defaults suit a tissue without a patient (a box): the
/// "face" is +y, up is +z.
struct PatientAxes {
  Vec3d left{1, 0, 0}, anterior{0, 1, 0}, superior{0, 0, 1};
  bool known = false;             ///< from a CT's frame or its anatomy (else no letters are shown)
  bool left_right_known = false;  ///< false: the CT records no left/right ("L?", "R?")
  /// One line for the HUD, e.g. "patient frame LPS (recorded); anterior from the anatomy".
  std::string description;
};

struct CameraOptions {
  /// Degrees about the patient's superior axis from a view facing the patient (from anterior).
  double azimuth_deg = 35.0;
  /// Degrees above the horizontal.
  double elevation_deg = 20.0;
  /// > 1 moves closer than the framing of the tissue's bounds.
  double zoom = 1.0;
  /// Point looked at, mm; NaN: the centre of the tissue's bounds.
  Vec3d focus_mm{std::nan(""), std::nan(""), std::nan("")};
};

struct SliceOptions {
  bool show = true;  ///< all three planes
  bool axial = true, coronal = true, sagittal = true;
  bool labels = true;  ///< colour the label overlay onto the grey
  /// Plane positions, mm (x: sagittal, y: coronal, z: axial); NaN: through the tissue's centre.
  Vec3d position_mm{std::nan(""), std::nan(""), std::nan("")};
  double opacity = 1.0;  ///< in (0, 1]
};

struct ViewOptions {
  int width = 1280, height = 800;  ///< pixels
  bool offscreen = false;
  CameraOptions camera;
  PatientAxes patient;
  SliceOptions slices;
  bool show_hud = true;
  bool show_plot = true;
  bool show_tool = true;
  /// Simulated seconds per simulation frame (the simulation thread paces it to real time).
  double frame_s = 1.0 / 120.0;
  /// Window: close by itself after this many rendered frames (< 0: when the user quits).
  int close_after_frames = -1;
  /// Window: close by itself after this many seconds of wall time (≤ 0: when the user quits).
  double close_after_s = 0;
  /// Window: runs once the haptic loop has started, on the render thread, before the simulation
  /// thread starts (tsf view lowers every other thread's priority below the haptic thread's).
  std::function<void()> on_haptics_started;

  /// Throws tsf::Error naming the field when a value is out of range.
  void validate() const;
};

}  // namespace tsf::viewer
