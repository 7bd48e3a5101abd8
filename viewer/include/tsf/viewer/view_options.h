// What the viewer shows and how: window, camera, slice planes, overlays. Defaults suit both the
// interactive window and offscreen frames; a view script (view_script.h) can set each of them.
#pragma once

#include <cmath>
#include <limits>

#include "tsf/common/vec3.h"

namespace tsf::viewer {

struct CameraOptions {
  /// Degrees about the up axis (z) from a view along −y (from the front, y is back → front).
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
  SliceOptions slices;
  bool show_hud = true;
  bool show_plot = true;
  bool show_tool = true;
  /// Simulated seconds per simulation frame (the simulation thread paces it to real time).
  double frame_s = 1.0 / 120.0;
  /// Window: close by itself after this many rendered frames (< 0: when the user quits).
  int close_after_frames = -1;

  /// Throws tsf::Error naming the field when a value is out of range.
  void validate() const;
};

}  // namespace tsf::viewer
