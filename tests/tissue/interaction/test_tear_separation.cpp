// Tearing through every layer: a spring the solver tears separates the voxels between its nodes,
// the surface re-meshes there, the coupler re-binds and the pieces come apart, on both backends.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "interaction_test_helpers.h"
#include "tsf/common/cuda_support.h"
#include "tsf/crms/lattice_builders.h"
#include "tsf/interaction/lattice_components.h"
#include "tsf/interaction/tear_separation.h"

namespace tsf::interaction {
namespace {

using test::block_options;
using test::block_volume;

crms::Lattice box_lattice(const Int3& nodes) {
  crms::BoxLatticeOptions o;
  o.size_mm = {double(nodes.x), double(nodes.y), double(nodes.z)};  // one node per 1 mm cell
  o.spacing_mm = 1.0;
  return crms::build_box_lattice(o);
}

bool holds(const std::vector<VoxelBox>& boxes, int i, int j, int k) {
  for (const VoxelBox& b : boxes)
    if (b.contains(i, j, k)) return true;
  return false;
}

TEST(TearSeparation, ATornInteriorSpringClearsTheTwoVoxelLayersOfItsFace) {
  crms::Lattice l = box_lattice({5, 5, 5});
  const int k = 2;
  const std::int64_t n = l.geometry().index(2, 2, 2);
  const int d = crms::make_direction(0, +1);
  l.break_spring(n, d);
  const TornVoxels t = torn_voxels(l, {{n, d}}, k, {10, 10, 10});
  EXPECT_TRUE(t.masked_nodes.empty());
  // The face between cells x = 2 and 3 lies between voxels 5 and 6: both layers, across the
  // 2 × 2 columns of the cell (y, z in [4, 6)), nothing else (every neighbour column holds).
  for (int kk = 0; kk < 10; ++kk)
    for (int j = 0; j < 10; ++j)
      for (int i = 0; i < 10; ++i) {
        const bool expected = (i == 5 || i == 6) && j >= 4 && j < 6 && kk >= 4 && kk < 6;
        EXPECT_EQ(holds(t.boxes, i, j, kk), expected) << i << "," << j << "," << kk;
      }
  // The same spring named from its upper end gives the same voxels.
  const TornVoxels u =
      torn_voxels(l, {{l.geometry().index(3, 2, 2), crms::make_direction(0, -1)}}, k, {10, 10, 10});
  EXPECT_EQ(u.bounds, t.bounds);
}

TEST(TearSeparation, AColumnWithoutAParallelSpringIsClearedToo) {
  // A plate two nodes thick; the torn spring runs along x on its top layer at the edge y = 0.
  // Across it: the column beside it in y and the one below in z hold parallel springs; beyond the
  // lattice (y < 0, or the voxels z = 4, 5 past the last node layer) nothing holds the sides.
  crms::Lattice l = box_lattice({4, 3, 2});
  const int k = 2;
  const std::int64_t n = l.geometry().index(1, 0, 1);
  const int d = crms::make_direction(0, +1);
  l.break_spring(n, d);
  const TornVoxels t = torn_voxels(l, {{n, d}}, k, {8, 6, 6});
  EXPECT_TRUE(holds(t.boxes, 3, 0, 2));  // n's own column
  EXPECT_TRUE(holds(t.boxes, 4, 1, 3));
  EXPECT_FALSE(holds(t.boxes, 3, 2, 2));  // the column at y = 1 holds its spring
  EXPECT_FALSE(holds(t.boxes, 3, 0, 0));  // so does the one below
  EXPECT_TRUE(holds(t.boxes, 3, 0, 5));   // voxels past the last node layer
  EXPECT_FALSE(holds(t.boxes, 2, 0, 2));  // only the two layers of the face
}

TEST(TearSeparation, ANodeLeftWithoutSpringsIsMaskedAndItsCellCleared) {
  crms::Lattice l = box_lattice({4, 4, 4});
  const int k = 2;
  const std::int64_t n = l.geometry().index(1, 1, 1);
  std::vector<crms::SpringRef> torn;
  for (int d = 0; d < crms::kFaceDirections; ++d) {
    l.break_spring(n, d);
    torn.push_back({n, d});
  }
  const TornVoxels t = torn_voxels(l, torn, k, {8, 8, 8});
  ASSERT_EQ(t.masked_nodes, std::vector<std::int64_t>{n});
  for (int kk = 2; kk < 4; ++kk)
    for (int j = 2; j < 4; ++j)
      for (int i = 2; i < 4; ++i) EXPECT_TRUE(holds(t.boxes, i, j, kk));
}

std::vector<crms::Backend> backends() {
  std::vector<crms::Backend> b = {crms::Backend::kCpu};
  if (cuda_status().available) b.push_back(crms::Backend::kCuda);
  return b;
}

/// Smallest distance between live vertices of two different surface components.
double gap_between_components(const imt::SurfaceMesh& mesh) {
  const imt::MeshTopology topo = imt::analyse_topology(mesh);
  if (topo.components < 2) return 0.0;
  // Label vertices by component (union over triangles).
  std::vector<std::uint32_t> parent(mesh.positions.size());
  for (std::uint32_t i = 0; i < parent.size(); ++i) parent[i] = i;
  auto find = [&](std::uint32_t x) {
    while (parent[x] != x) x = parent[x] = parent[parent[x]];
    return x;
  };
  for (const auto& t : mesh.triangles) {
    const std::uint32_t a = find(t[0]);
    parent[find(t[1])] = a;
    parent[find(t[2])] = a;
  }
  double best = std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i < mesh.positions.size(); i += 3)
    for (std::size_t j = i + 1; j < mesh.positions.size(); j += 3)
      if (find(static_cast<std::uint32_t>(i)) != find(static_cast<std::uint32_t>(j)))
        best = std::min(best, double(length(mesh.positions[i] - mesh.positions[j])));
  return best;
}

TEST(TearSeparation, ABarPulledApartTearsIntoTwoClosedPiecesThroughEveryLayer) {
  for (crms::Backend backend : backends()) {
    SCOPED_TRACE(crms::to_string(backend));
    TissueModelOptions o = block_options(6.0, 0.0);
    o.solver.backend = backend;
    o.solver.effects.tearing.enabled = true;
    o.solver.effects.tearing.strain_threshold = 0.3;
    TissueModel model(block_volume({44, 12, 12}, {2, 2, 2}, {42, 10, 10}), std::move(o));
    ASSERT_EQ(model.lattice_components(), 1u);
    ASSERT_EQ(imt::analyse_topology(model.deformed_mesh()).components, 1u);
    if (backend == crms::Backend::kCpu && !cuda_status().available)
      std::printf("CUDA run of this test skipped: %s\n", cuda_status().reason.c_str());

    // A nick at x = 23 from the side y = 2 to y = 6 (half the width), then forceps pull the last
    // node layers along +x by 0.4 mm per frame.
    Tool blade;
    blade.shape = collision::ToolShape::kBlade;
    blade.half_extents_mm = {9.0, 3.0, 0.5};
    const Rotation across_x = Rotation::about_axis({0, 1, 0}, M_PI / 2);
    model.apply_tool(blade, {{23, 3.0, 6}, across_x}, ToolMode::kCut);
    model.release_tool();
    ASSERT_EQ(model.lattice_components(), 1u) << "the nick alone must not separate the bar";

    const crms::Lattice& l = model.solver().lattice();
    std::vector<std::int64_t> far;
    for (std::int64_t n = 0; n < l.node_count(); ++n)
      if (l.alive(n) && l.geometry().rest_position(n).x > 38.0) far.push_back(n);
    ASSERT_FALSE(far.empty());
    TearReport first_tear;
    int frames = 0;
    for (; frames < 200 && model.lattice_components() < 2; ++frames) {
      std::vector<Vec3d> targets;
      for (std::int64_t n : far)
        targets.push_back(l.geometry().rest_position(n) + Vec3d{0.4 * (frames + 1), 0, 0});
      model.solver().constrain_nodes(far, targets);
      const AdvanceReport a = model.advance(1e-3);
      ASSERT_FALSE(a.instability) << a.instability->describe();
      if (a.tear.any() && !first_tear.any()) first_tear = a.tear;
    }
    ASSERT_EQ(model.lattice_components(), 2u) << "no tear after " << frames << " frames";
    EXPECT_GT(first_tear.springs_torn, 0u);
    EXPECT_TRUE(first_tear.layers.edited) << "the tear cleared no voxel";
    EXPECT_GT(first_tear.cleared_mm3, 0.0);
    EXPECT_GT(first_tear.layers.vertices_rebound, 0u);
    EXPECT_EQ(model.totals().springs_torn, static_cast<std::size_t>(model.solver().torn_springs()));

    // Pull on: the surface is two closed pieces that come apart.
    for (int f = 0; f < 20; ++f) {
      std::vector<Vec3d> targets;
      for (std::int64_t n : far)
        targets.push_back(l.geometry().rest_position(n) + Vec3d{0.4 * (frames + f + 1), 0, 0});
      model.solver().constrain_nodes(far, targets);
      model.advance(1e-3);
    }
    ASSERT_TRUE(test::all_finite(model));
    const imt::SurfaceMesh mesh = model.deformed_mesh();
    EXPECT_TRUE(test::closed_manifold(mesh));
    EXPECT_EQ(imt::analyse_topology(mesh).components, 2u);
    EXPECT_GT(gap_between_components(mesh), 2.0) << "the two pieces must have come apart";
  }
}

TEST(TearSeparation, CutTriggersFireOnATearAsOnACut) {
  TissueModelOptions o = block_options(6.0, 0.0);
  o.solver.effects.tearing.enabled = true;
  o.solver.effects.tearing.strain_threshold = 0.3;
  o.solver.materials.resize(2);
  o.solver.materials[1] = o.solver.materials[0];
  o.solver.materials[1].youngs_modulus_pa *= 0.5;
  o.solver.effects.animation.enabled = true;
  o.configure_effects = [](const crms::Lattice& l, crms::SolverConfig& c) {
    crms::CutTrigger t;
    t.name = "torn-region";
    t.entry = 1;
    for (std::int64_t n = 0; n < l.node_count(); ++n)
      if (l.alive(n)) t.nodes.push_back(n);
    c.effects.animation.cut_triggers = {t};
  };
  TissueModel model(block_volume({24, 10, 10}, {2, 2, 2}, {22, 8, 8}), std::move(o));
  const crms::Lattice& l = model.solver().lattice();
  std::vector<std::int64_t> far;
  for (std::int64_t n = 0; n < l.node_count(); ++n)
    if (l.alive(n) && l.geometry().rest_position(n).x > 18.0) far.push_back(n);
  EXPECT_TRUE(model.solver().fired_triggers().empty());
  for (int f = 0; f < 100 && model.totals().springs_torn == 0; ++f) {
    std::vector<Vec3d> targets;
    for (std::int64_t n : far)
      targets.push_back(l.geometry().rest_position(n) + Vec3d{0.5 * (f + 1), 0, 0});
    model.solver().constrain_nodes(far, targets);
    model.advance(1e-3);
  }
  ASSERT_GT(model.totals().springs_torn, 0u);
  EXPECT_EQ(model.solver().fired_triggers(), std::vector<std::string>{"torn-region"});
}

TEST(TearSeparation, WithoutTearingAnAdvanceTakesNoTornSprings) {
  TissueModel model(block_volume({24, 10, 10}, {2, 2, 2}, {22, 8, 8}), block_options(6.0));
  const AdvanceReport a = model.advance(1e-3);
  EXPECT_FALSE(a.tear.any());
  EXPECT_TRUE(model.solver().take_torn_springs().empty());
}

}  // namespace
}  // namespace tsf::interaction
