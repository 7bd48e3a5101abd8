// View scripts: what `tsf view SCENE --offscreen --script FILE` renders, frame by frame. YAML,
// validated strictly (an unknown key or an out-of-range value is an error naming the file and
// the key path). Every key is optional:
//
//   frame_time: 0.002            # simulated seconds per rendered frame (default 1/120)
//   width: 1280                  # pixels
//   height: 800
//   camera: {azimuth: 35, elevation: 20, zoom: 1.0, focus: [x, y, z]}   # degrees, mm
//   slices: {show: true, axial: true, coronal: true, sagittal: true, labels: true,
//            position: [x, y, z], opacity: 1.0}                        # mm
//   hud: true
//   plot: true
//   tool: true                   # draw the tool
//   keyframes:                   # the hands: which tool, where, in which mode, from which frame
//     - {frame: 0,  tool: wand, position: [10, 6, 16], rotation: {axis: [1, 0, 0], angle_deg: 90},
//     mode: idle}
//     - {frame: 10, tool: wand, position: [10, 6, 12], mode: ablate}
//     - {frame: 4, hand: 1, tool: ball, position: [30, 8, 13], mode: press}   # a second hand
//
// Each hand (`hand:`, 0 when left out) is its own sequence of keyframes: between two of them the
// pose is interpolated (interaction/trajectory.h: position linear, rotation slerp) and the mode of
// the earlier keyframe holds; the tool of a keyframe is held from it until the next. A keyframe
// without `rotation` keeps the hand's previous one. Before its first keyframe a hand is empty
// (idle, no tool drawn). Hands act at once, each tool in its own slot (two-handed work).
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "tsf/interaction/trajectory.h"
#include "tsf/viewer/simulation_session.h"
#include "tsf/viewer/view_options.h"

namespace tsf::viewer {

/// One hand's keyframes.
struct ViewHand {
  interaction::Trajectory path;     ///< time = frame index
  std::vector<int> keyframe_tools;  ///< tool index per keyframe

  /// The hand at `frame` (idle with tool 0 before the first keyframe).
  ToolCommand command_at(int frame) const;
  bool holds_tool_at(int frame) const;
};

/// The most hands a view script moves at once.
constexpr int kMaxHands = 8;

struct ViewScript {
  ViewOptions options;
  std::vector<ViewHand> hands;  ///< hand 0 first; may be empty (no keyframes)

  /// Hand 0 at `frame` (idle with tool 0 when there is no hand).
  ToolCommand command_at(int frame) const;
  bool holds_tool_at(int frame) const;
  /// Every hand at `frame`; an empty hand has tool −1.
  std::vector<ToolCommand> commands_at(int frame) const;
  /// The last keyframe of any hand (frames), −1 when there is none.
  double last_keyframe() const;
};

/// Reads a view script; `tools` are the scene's (keyframes name them). `defaults` are the options
/// the script starts from. Throws tsf::Error "FILE: key.path: what is wrong".
ViewScript read_view_script(const std::filesystem::path& file, const std::vector<NamedTool>& tools,
                            const ViewOptions& defaults);

}  // namespace tsf::viewer
