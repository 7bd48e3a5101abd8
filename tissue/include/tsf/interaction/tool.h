// Interaction tools and what they do (docs/design.md "Cutting, ablation, collisions").
//
// A tool is a shape with a pose in the deformed world (tissue space as the tissue looks now, mm):
//   sphere   radius                      press, ablate (a ball probe or burr)
//   capsule  radius, half_length along    press, ablate (the ablation wand)
//            the pose's local z
//   blade    half extents along the       press, cut (an oriented box: length x, depth y,
//            pose's local x, y, z          thickness z)
//   mesh     a closed mesh in the pose's   press (an endoscope, a retractor: any shape, kept
//            frame (ToolMesh)              out of the tissue through its distance grid)
// Modes: press pushes tissue (contact constraints, reaction force); ablate removes tissue along
// the tool's path; cut clears the slab a blade sweeps; idle does nothing (the tool is lifted).
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "tsf/collision/distance_grid.h"
#include "tsf/collision/world_tool.h"
#include "tsf/volume/tool_shapes.h"

namespace tsf::interaction {

enum class ToolMode { kIdle, kPress, kAblate, kCut };

const char* to_string(ToolMode mode);
/// "idle" | "press" | "ablate" | "cut"; throws tsf::Error naming the text otherwise.
ToolMode tool_mode_from_string(const std::string& text);
const char* to_string(collision::ToolShape shape);

/// A tool made from a closed mesh (the app reads it from an OBJ, STL or PLY file): its surface for
/// drawing and its signed-distance grid for contact, both in the tool's own frame (mm).
struct ToolMesh {
  std::string source;  ///< where it came from (a file name), for messages and reports
  std::vector<Vec3f> vertices;
  std::vector<std::array<std::uint32_t, 3>> triangles;
  collision::SignedDistanceGrid grid;

  /// The grid of the closed mesh at `spacing_mm`; throws tsf::Error naming `source` when the mesh
  /// is not closed or the grid is too large.
  static std::shared_ptr<const ToolMesh> from_closed_mesh(
      std::string source, std::vector<Vec3f> vertices,
      std::vector<std::array<std::uint32_t, 3>> triangles, double spacing_mm);
};

struct Tool {
  collision::ToolShape shape = collision::ToolShape::kSphere;
  double radius_mm = 1.0;                 ///< sphere, capsule; > 0
  double half_length_mm = 0.0;            ///< capsule: half its axis length (0 = a sphere); ≥ 0
  Vec3d half_extents_mm{5.0, 5.0, 0.25};  ///< blade; each > 0
  std::shared_ptr<const ToolMesh> mesh;   ///< mesh: required

  /// Throws tsf::Error naming the field when a value is out of range or not finite.
  void validate() const;
  /// Whether this tool can run `mode` (ablate: sphere or capsule; cut: blade; press: any).
  bool supports(ToolMode mode) const;
  /// Same shape and size (and the same mesh).
  bool same_as(const Tool& other) const;
};

/// The tool at `pose` in the deformed world (a mesh tool points at its grid: the Tool must outlive
/// the WorldTool).
collision::WorldTool place_tool(const Tool& tool, const ToolPose& pose);

}  // namespace tsf::interaction
