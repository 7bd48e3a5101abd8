// Scenes and assertions shared by the deform/cut tests: a soft block of tissue voxels, model
// options with a calibrated soft material, and checks on surfaces, nodes and coupled vertices.
#pragma once

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

#include "tsf/collision/world_tool.h"
#include "tsf/crms/lattice_builders.h"
#include "tsf/imt/mesh_topology.h"
#include "tsf/interaction/tissue_model.h"
#include "tsf/volume/analytic_volumes.h"
#include "tsf/volume/tool_shapes.h"

namespace tsf::interaction::test {

/// A block of tissue [lo, hi] mm (density ramp over ±0.5 mm) in a volume of `dims` 1 mm voxels.
inline VoxelVolume block_volume(const Int3& dims, const Vec3d& lo, const Vec3d& hi) {
  const Vec3d centre = (lo + hi) * 0.5, half = (hi - lo) * 0.5;
  return make_sdf_volume(
      cube_geometry(dims, 1.0),
      [&](const Vec3d& p) { return box_distance_local(half, p - centre); }, 0.5);
}

/// Soft tissue (E = 200 kPa, η = 5 Pa·s, water density), k = 2 voxels per node, anchored where
/// the rest x of a node is below `anchor_x_mm` (none when negative).
inline TissueModelOptions block_options(double anchor_x_mm, double gravity_mm_s2 = -9810.0) {
  TissueModelOptions o;
  o.lattice.node_spacing_voxels = 2;
  o.solver.materials[0].youngs_modulus_pa = 200e3;
  o.solver.materials[0].viscosity_pa_s = 5.0;
  o.solver.materials[0].density_g_per_mm3 = 1e-3;
  o.solver.gravity = {0, 0, gravity_mm_s2};
  o.solver.backend = crms::Backend::kCpu;
  o.solver.stability.kinetic_damping = 0.01;
  if (anchor_x_mm >= 0)
    o.anchor = [anchor_x_mm](crms::Lattice& l) {
      crms::fix_nodes_in_box(l, {-1e9, -1e9, -1e9}, {anchor_x_mm, 1e9, 1e9});
    };
  return o;
}

/// Every live vertex of the deformed mesh and every alive node finite.
inline ::testing::AssertionResult all_finite(const TissueModel& model) {
  const auto& p = model.coupler().positions();
  const auto& n = model.coupler().normals();
  for (std::uint32_t s = 1; s < model.surface().vertex_slot_count(); ++s) {
    if (!model.surface().vertex_live(s)) continue;
    if (!tsf::all_finite(p[s]) || !tsf::all_finite(n[s]))
      return ::testing::AssertionFailure() << "coupled vertex slot " << s << " is not finite";
  }
  if (model.solver().instability())
    return ::testing::AssertionFailure() << model.solver().instability()->describe();
  const auto pos = model.solver().positions();
  for (std::size_t i = 0; i < pos.size(); ++i)
    if (model.solver().lattice().alive(static_cast<std::int64_t>(i)) && !tsf::all_finite(pos[i]))
      return ::testing::AssertionFailure() << "node " << i << " is not finite";
  return ::testing::AssertionSuccess();
}

/// The deformed surface's deepest point inside `tool`, mm (0 when nothing is inside), over
/// coupled vertices; `nodes_depth` receives the same over alive nodes.
inline double deepest_inside(const TissueModel& model, const collision::WorldTool& tool,
                             double* nodes_depth = nullptr) {
  double worst = 0;
  const auto& p = model.coupler().positions();
  for (std::uint32_t s = 1; s < model.surface().vertex_slot_count(); ++s) {
    if (!model.surface().vertex_live(s)) continue;
    Vec3d n;
    worst = std::max(worst, -collision::tool_distance(tool, to_double(p[s]), n));
  }
  if (nodes_depth) {
    *nodes_depth = 0;
    const auto pos = model.solver().positions();
    for (std::size_t i = 0; i < pos.size(); ++i) {
      if (!model.solver().lattice().alive(static_cast<std::int64_t>(i))) continue;
      Vec3d n;
      *nodes_depth = std::max(*nodes_depth, -collision::tool_distance(tool, to_double(pos[i]), n));
    }
  }
  return worst;
}

/// The render surface is a closed, consistently oriented 2-manifold.
inline ::testing::AssertionResult closed_manifold(const imt::SurfaceMesh& mesh) {
  const imt::MeshTopology t = imt::analyse_topology(mesh);
  if (t.closed_oriented_manifold()) return ::testing::AssertionSuccess();
  return ::testing::AssertionFailure()
         << "boundary edges " << t.boundary_edges << ", non-manifold edges " << t.nonmanifold_edges
         << ", misoriented " << t.misoriented_edges << ", pinched vertices "
         << t.nonmanifold_vertices << ", unreferenced " << t.unreferenced_vertices
         << ", degenerate " << t.degenerate_triangles;
}

}  // namespace tsf::interaction::test
