#include "tsf/interaction/tool.h"

#include <cmath>

#include "tsf/common/error.h"

namespace tsf::interaction {

const char* to_string(ToolMode mode) {
  switch (mode) {
    case ToolMode::kIdle:
      return "idle";
    case ToolMode::kPress:
      return "press";
    case ToolMode::kAblate:
      return "ablate";
    case ToolMode::kCut:
      return "cut";
  }
  return "unknown";
}

ToolMode tool_mode_from_string(const std::string& text) {
  for (ToolMode m : {ToolMode::kIdle, ToolMode::kPress, ToolMode::kAblate, ToolMode::kCut})
    if (text == to_string(m)) return m;
  throw Error("tool mode: expected idle, press, ablate or cut, got '" + text + "'");
}

const char* to_string(collision::ToolShape shape) {
  switch (shape) {
    case collision::ToolShape::kSphere:
      return "sphere";
    case collision::ToolShape::kCapsule:
      return "capsule";
    case collision::ToolShape::kBlade:
      return "blade";
    case collision::ToolShape::kMesh:
      return "mesh";
    case collision::ToolShape::kField:
      return "body";
  }
  return "unknown";
}

void Tool::validate() const {
  using collision::ToolShape;
  if (shape == ToolShape::kSphere || shape == ToolShape::kCapsule) {
    if (!(std::isfinite(radius_mm) && radius_mm > 0 && radius_mm <= 1e3))
      throw Error("tool.radius: expected a radius in (0, 1000] mm, got " +
                  std::to_string(radius_mm));
  }
  if (shape == ToolShape::kCapsule) {
    if (!(std::isfinite(half_length_mm) && half_length_mm >= 0 && half_length_mm <= 1e3))
      throw Error("tool.half_length: expected [0, 1000] mm, got " + std::to_string(half_length_mm));
  }
  if (shape == ToolShape::kMesh && !mesh) throw Error("tool.mesh: a mesh tool needs its mesh");
  if (shape == ToolShape::kField) throw Error("tool.shape: a body is not a tool a hand holds");
  if (shape == ToolShape::kBlade) {
    for (int a = 0; a < 3; ++a)
      if (!(std::isfinite(half_extents_mm[a]) && half_extents_mm[a] > 0 &&
            half_extents_mm[a] <= 1e3))
        throw Error("tool.half_extents: each must be in (0, 1000] mm, got " +
                    std::to_string(half_extents_mm[a]));
  }
}

bool Tool::supports(ToolMode mode) const {
  using collision::ToolShape;
  switch (mode) {
    case ToolMode::kIdle:
    case ToolMode::kPress:
      return true;
    case ToolMode::kAblate:
      return shape == ToolShape::kSphere || shape == ToolShape::kCapsule;
    case ToolMode::kCut:
      return shape == ToolShape::kBlade;
  }
  return false;
}

bool Tool::same_as(const Tool& o) const {
  return shape == o.shape && radius_mm == o.radius_mm && half_length_mm == o.half_length_mm &&
         half_extents_mm == o.half_extents_mm && mesh == o.mesh;
}

std::shared_ptr<const ToolMesh> ToolMesh::from_closed_mesh(
    std::string source, std::vector<Vec3f> vertices,
    std::vector<std::array<std::uint32_t, 3>> triangles, double spacing_mm) {
  auto m = std::make_shared<ToolMesh>();
  try {
    m->grid = collision::SignedDistanceGrid::from_closed_mesh(vertices, triangles, spacing_mm,
                                                              3.0 * spacing_mm);
  } catch (const Error& e) {
    throw Error(source + ": " + e.what());
  }
  m->source = std::move(source);
  m->vertices = std::move(vertices);
  m->triangles = std::move(triangles);
  return m;
}

collision::WorldTool place_tool(const Tool& tool, const ToolPose& pose) {
  collision::WorldTool w;
  w.shape = tool.shape;
  w.radius = tool.radius_mm;
  w.pose = {pose.position, pose.orientation.normalized()};
  w.a = w.b = pose.position;
  if (tool.shape == collision::ToolShape::kCapsule) {
    const Vec3d axis = w.pose.orientation.apply(Vec3d{0, 0, tool.half_length_mm});
    w.a = pose.position - axis;
    w.b = pose.position + axis;
  }
  w.half_extents = tool.half_extents_mm;
  if (tool.shape == collision::ToolShape::kMesh) w.grid = &tool.mesh->grid;
  return w;
}

}  // namespace tsf::interaction
