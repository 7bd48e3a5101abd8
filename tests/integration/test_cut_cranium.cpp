// Cutting and ablating the sample cranium through every layer: 1,000 random strokes (balls,
// wands, blades) and presses on the real CT around the nasal cavity and sinuses, with the
// lattice simulated between them. Every 100 edits:
//   no NaN in nodes or coupled vertices; the render surface is a closed, consistently oriented
//   manifold (no dangling vertices, no non-manifold edges); the IMT buffers pass their invariant
//   check; every live vertex is bound with a frame to follow (no orphan, no vertex whose cube's
//   sources are all deleted); the incremental bindings equal binding afresh.
// Density: the sample CT through a smooth HU ramp (0 → 1 over −300 ± 100 HU).
#include <gtest/gtest.h>
#include <itkImage.h>
#include <itkImageFileReader.h>

#include <algorithm>
#include <random>
#include <string>

#include "support/test_data.h"
#include "tsf/common/error.h"
#include "tsf/common/stopwatch.h"
#include "tsf/coupler/coupler.h"
#include "tsf/import/itk_io_factories.h"
#include "tsf/imt/mesh_topology.h"
#include "tsf/interaction/tissue_model.h"

namespace tsf {
namespace {

/// The sample CT (HU) cropped to voxels [lo, hi), as density through the −300 HU ramp.
VoxelVolume cranium_crop(const Int3& lo, const Int3& hi) {
  import::register_itk_io_factories();
  using Image = itk::Image<float, 3>;
  auto reader = itk::ImageFileReader<Image>::New();
  reader->SetFileName((test::samples_dir() / "ct-head-cranium" / "cranium.nrrd").string());
  reader->Update();
  const Image* im = reader->GetOutput();
  const auto size = im->GetLargestPossibleRegion().GetSize();
  VolumeGeometry g;
  g.dims = {hi.x - lo.x, hi.y - lo.y, hi.z - lo.z};
  g.spacing = {im->GetSpacing()[0], im->GetSpacing()[1], im->GetSpacing()[2]};
  g.origin = {im->GetOrigin()[0] + lo.x * g.spacing.x, im->GetOrigin()[1] + lo.y * g.spacing.y,
              im->GetOrigin()[2] + lo.z * g.spacing.z};
  VoxelVolume v(g);
  const float* hu = im->GetBufferPointer();
  float* d = v.density_for_tracked_write();
  std::uint8_t* l = v.labels_for_tracked_write();
  for (int k = 0; k < g.dims.z; ++k)
    for (int j = 0; j < g.dims.y; ++j)
      for (int i = 0; i < g.dims.x; ++i) {
        const std::size_t src = static_cast<std::size_t>(i + lo.x) +
                                size[0] * (static_cast<std::size_t>(j + lo.y) +
                                           size[1] * static_cast<std::size_t>(k + lo.z));
        const std::size_t dst = v.index(i, j, k);
        d[dst] = static_cast<float>(std::clamp(0.5 + (double(hu[src]) + 300.0) / 200.0, 0.0, 1.0));
        l[dst] = d[dst] >= 0.5f ? kLabelSoftTissue : kLabelOutside;
      }
  v.mark_all_modified();
  return v;
}

::testing::AssertionResult consistent(const interaction::TissueModel& model,
                                      const std::string& when) {
  if (model.solver().instability())
    return ::testing::AssertionFailure()
           << when << ": " << model.solver().instability()->describe();
  const auto pos = model.solver().positions();
  for (std::size_t n = 0; n < pos.size(); ++n)
    if (model.solver().lattice().alive(static_cast<std::int64_t>(n)) && !all_finite(pos[n]))
      return ::testing::AssertionFailure() << when << ": node " << n << " is not finite";
  try {
    model.surface().check_invariants();
  } catch (const Error& e) {
    return ::testing::AssertionFailure() << when << ": IMT invariant: " << e.what();
  }
  const imt::SurfaceMesh mesh = model.deformed_mesh();
  for (std::size_t i = 0; i < mesh.vertex_count(); ++i)
    if (!all_finite(mesh.positions[i]) || !all_finite(mesh.normals[i]))
      return ::testing::AssertionFailure() << when << ": coupled vertex " << i << " not finite";
  const imt::MeshTopology t = imt::analyse_topology(mesh);
  if (t.unreferenced_vertices || t.nonmanifold_edges || t.boundary_edges || t.misoriented_edges ||
      t.nonmanifold_vertices || t.degenerate_triangles)
    return ::testing::AssertionFailure()
           << when << ": dangling " << t.unreferenced_vertices << ", non-manifold edges "
           << t.nonmanifold_edges << ", boundary " << t.boundary_edges << ", misoriented "
           << t.misoriented_edges << ", pinched " << t.nonmanifold_vertices;
  const coupler::Coupler& c = model.coupler();
  coupler::Coupler fresh(model.solver().lattice().geometry(), c.options());
  fresh.bind_all(model.surface(), model.solver().lattice());
  std::size_t unbound = 0, orphans = 0, mismatched = 0;
  for (std::uint32_t s = 1; s < model.surface().vertex_slot_count(); ++s) {
    if (!model.surface().vertex_live(s)) continue;
    const coupler::VertexBinding& b = c.bindings()[s];
    const coupler::VertexBinding& f = fresh.bindings()[s];
    unbound += b.cell < 0;
    orphans += c.sources()[s] == 0;
    mismatched += b.cell != f.cell || c.sources()[s] != fresh.sources()[s] || b.w[0] != f.w[0] ||
                  b.w[1] != f.w[1] || b.w[2] != f.w[2];
  }
  if (unbound || orphans || mismatched)
    return ::testing::AssertionFailure()
           << when << ": " << unbound << " unbound, " << orphans << " without a frame, "
           << mismatched << " differing from a fresh binding";
  return ::testing::AssertionSuccess();
}

TEST(CutCranium, ThousandRandomCutsAndAblationsKeepEveryLayerConsistent) {
  // Around the nasal cavity and maxillary sinuses: 128 × 128 × 56 voxels of the sample CT.
  interaction::TissueModelOptions o;
  o.lattice.node_spacing_voxels = 2;
  o.solver.materials[0].youngs_modulus_pa = 30e3;
  o.solver.materials[0].viscosity_pa_s = 5.0;
  o.solver.gravity = {0, 0, -9810};
  o.solver.backend = crms::Backend::kCpu;
  o.solver.stability.kinetic_damping = 0.01;
  o.anchor = [](crms::Lattice& l) {  // the skull base holds the rest
    const crms::LatticeGeometry& g = l.geometry();
    crms::fix_nodes_in_box(l, {-1e9, -1e9, -1e9}, {1e9, 1e9, g.origin.z + 2.5 * g.spacing.z});
  };
  interaction::TissueModel model(cranium_crop({64, 64, 0}, {192, 192, 56}), o);
  ASSERT_TRUE(consistent(model, "at start"));
  const std::size_t start_vertices = model.surface().live_vertex_count();
  ASSERT_GT(start_vertices, 100000u);

  std::mt19937 rng(1000);
  std::uniform_real_distribution<double> unit(-1, 1), u01(0, 1);
  interaction::Tool ball, wand, blade;
  wand.shape = collision::ToolShape::kCapsule;
  wand.half_length_mm = 3.0;
  blade.shape = collision::ToolShape::kBlade;
  blade.half_extents_mm = {6.0, 4.0, 0.3};
  std::size_t edits = 0;
  double t_edit = 0, t_step = 0, t_check = 0;
  for (int op = 0; op < 1000; ++op) {
    Stopwatch clock;
    // Aim at the deformed surface: a random live vertex, a little offset.
    std::uint32_t slot =
        1 + static_cast<std::uint32_t>(u01(rng) * (model.surface().vertex_slot_count() - 2));
    while (!model.surface().vertex_live(slot))
      slot = 1 + slot % (model.surface().vertex_slot_count() - 1);
    const Vec3d at =
        to_double(model.coupler().positions()[slot]) + Vec3d{unit(rng), unit(rng), unit(rng)};
    const Rotation r =
        Rotation::about_axis({unit(rng), unit(rng), unit(rng) + 1e-3}, 3.0 * unit(rng));
    const Vec3d step{2 * unit(rng), 2 * unit(rng), 2 * unit(rng)};
    const int kind = op % 7;
    interaction::EditReport e;
    if (kind < 3) {
      ball.radius_mm = 1.0 + 3.0 * u01(rng);
      model.apply_tool(ball, {at, r}, interaction::ToolMode::kAblate);
      e = model.apply_tool(ball, {at + step, r}, interaction::ToolMode::kAblate);
    } else if (kind < 5) {
      wand.radius_mm = 0.8 + 1.5 * u01(rng);
      model.apply_tool(wand, {at, r}, interaction::ToolMode::kAblate);
      e = model.apply_tool(wand, {at + step, r}, interaction::ToolMode::kAblate);
    } else if (kind == 5) {
      model.apply_tool(blade, {at, r}, interaction::ToolMode::kCut);
      e = model.apply_tool(blade, {at + step * 2.0, r}, interaction::ToolMode::kCut);
    } else {
      ball.radius_mm = 2.0;
      model.apply_tool(ball, {at, r}, interaction::ToolMode::kPress);
    }
    edits += e.edited;
    t_edit += clock.seconds();
    clock.restart();
    if (op % 25 == 24) model.advance(model.dt() * 2);  // a little simulation between strokes
    model.release_tool();
    t_step += clock.seconds();
    clock.restart();
    if (op % 100 == 99) {
      ASSERT_TRUE(consistent(model, "after " + std::to_string(op + 1) + " operations"));
    }
    t_check += clock.seconds();
  }
  std::printf(
      "cranium crop: %zu vertices, %lld nodes alive; edits %.1f s, simulation %.1f s, "
      "checks %.1f s\n",
      model.surface().live_vertex_count(), static_cast<long long>(model.alive_nodes()), t_edit,
      t_step, t_check);
  EXPECT_GT(edits, 600u) << "most strokes must hit tissue";
  EXPECT_GT(model.totals().nodes_deleted, 0u);
  EXPECT_GT(model.totals().springs_broken, 0u);
}

}  // namespace
}  // namespace tsf
