// Interaction tools and what they do (docs/design.md "Cutting, ablation, collisions").
//
// A tool is a shape with a pose in the deformed world (tissue space as the tissue looks now, mm):
//   sphere   radius                      press, ablate (a ball probe or burr)
//   capsule  radius, half_length along    press, ablate (the ablation wand)
//            the pose's local z
//   blade    half extents along the       press, cut (an oriented box: length x, depth y,
//            pose's local x, y, z          thickness z)
// Modes: press pushes tissue (contact constraints, reaction force); ablate removes tissue along
// the tool's path; cut clears the slab a blade sweeps; idle does nothing (the tool is lifted).
#pragma once

#include <string>

#include "tsf/collision/world_tool.h"
#include "tsf/volume/tool_shapes.h"

namespace tsf::interaction {

enum class ToolMode { kIdle, kPress, kAblate, kCut };

const char* to_string(ToolMode mode);
/// "idle" | "press" | "ablate" | "cut"; throws tsf::Error naming the text otherwise.
ToolMode tool_mode_from_string(const std::string& text);
const char* to_string(collision::ToolShape shape);

struct Tool {
  collision::ToolShape shape = collision::ToolShape::kSphere;
  double radius_mm = 1.0;                 ///< sphere, capsule; > 0
  double half_length_mm = 0.0;            ///< capsule: half its axis length (0 = a sphere); ≥ 0
  Vec3d half_extents_mm{5.0, 5.0, 0.25};  ///< blade; each > 0

  /// Throws tsf::Error naming the field when a value is out of range or not finite.
  void validate() const;
  /// Whether this tool can run `mode` (ablate: sphere or capsule; cut: blade).
  bool supports(ToolMode mode) const;
};

/// The tool at `pose` in the deformed world.
collision::WorldTool place_tool(const Tool& tool, const ToolPose& pose);

}  // namespace tsf::interaction
