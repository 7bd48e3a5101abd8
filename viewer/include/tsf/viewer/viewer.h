// The tsf viewer window: the deforming, cuttable tissue, CT slice planes with the label overlay,
// the tool, a heads-up display and a live plot of tool force and simulation rate.
//
//   SimulationSession session(std::move(model), tools);
//   Viewer viewer(session, &slices, options);  // slices: slice_volume.h (CT + labels)
//   viewer.run_window();                 // interactive: simulation on its own thread
//
//   Viewer viewer(session, nullptr, offscreen_options);
//   viewer.step_and_render(command);     // offscreen: one simulated frame, then render
//   viewer.write_png("frame-0000.png");
//
// Rendering reads the latest surface the simulation published (surface_exchange.h) and copies only
// the changed vertex ranges (surface_uploader.h). Coordinates: tissue space, mm; the slice volume
// is shown at rest (it is the scan), the surface deformed.
//
// Needs an X server (Debian's VTK renders through X only; Xvfb for offscreen): check with
// x_display_status() first, since VTK aborts the process when it cannot open the display.
#pragma once

#include <array>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "tsf/viewer/simulation_session.h"
#include "tsf/viewer/slice_volume.h"
#include "tsf/viewer/view_options.h"
#include "tsf/viewer/view_script.h"
#include "tsf/volume/voxel_volume.h"

namespace tsf::viewer {

struct DisplayStatus {
  bool available = false;
  std::string reason;  ///< why not (DISPLAY unset, cannot open it)
};
/// Whether an X display can be opened ($DISPLAY).
DisplayStatus x_display_status();

/// An RGB frame, rows bottom to top (VTK order).
struct Frame {
  int width = 0, height = 0;
  std::vector<std::uint8_t> rgb;  ///< width × height × 3
  std::array<std::uint8_t, 3> at(int x, int y) const {
    const std::size_t i = 3 * (static_cast<std::size_t>(y) * width + x);
    return {rgb[i], rgb[i + 1], rgb[i + 2]};
  }
};

/// Interactive keys (also printed by --help and the window's help line).
extern const char* const kViewerKeyHelp;

class ToolInteractorStyle;

class Viewer {
 public:
  /// `slices` (may be null: the model's own density and labels) is what the slice planes cut; it
  /// is copied to an image once. Throws tsf::Error when options are invalid or there is no display.
  Viewer(SimulationSession& session, const SliceVolume* slices, const ViewOptions& options);
  ~Viewer();
  Viewer(const Viewer&) = delete;
  Viewer& operator=(const Viewer&) = delete;

  /// Opens the window and runs until the user quits (q, Esc, closing it), close_after_frames or
  /// close_after_s. The simulation runs on its own thread meanwhile, and the session's live
  /// haptics (if attached) on theirs. With a `script`, its hands play in wall-clock time (frame
  /// f at f·frame_s seconds) instead of the mouse. Returns the number of frames rendered.
  int run_window(const ViewScript* script = nullptr);

  /// Offscreen (or a window driven by the caller): simulates one frame with `command` on this
  /// thread, then renders it. The tool is drawn where `command` holds it.
  void step_and_render(const ToolCommand& command);
  /// Renders the latest published state without simulating.
  void render(const ToolCommand& command);
  /// The same with every hand's tool drawn (an empty hand: tool −1).
  void render_hands(const std::vector<ToolCommand>& hands);
  /// |force| shown in the HUD and plot by the last render: the haptic force with live haptics,
  /// else the tools' contact force, µN.
  double shown_force_un() const;
  Frame capture() const;
  /// Writes the last rendered frame as PNG (atomically: a temporary file, then rename).
  void write_png(const std::filesystem::path& path) const;

  /// Display pixel (x, y from the bottom left) of a tissue-space point in the current camera.
  std::array<double, 2> world_to_pixel(const Vec3d& p) const;
  const ViewOptions& options() const { return options_; }
  /// Mean wall-clock seconds of the last renders (upload + draw).
  double render_seconds() const;

 private:
  friend class ToolInteractorStyle;  // the mouse and keys drive the hand (viewer.cpp)
  struct Impl;
  std::unique_ptr<Impl> impl_;
  ViewOptions options_;
};

}  // namespace tsf::viewer
