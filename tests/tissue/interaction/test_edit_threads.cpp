// The edit path shares its work among the OpenMP threads: the blade sweep's sub-steps, the IMT
// re-mesh's lattice windows, vertex tables and refresh plans (a batch of chunks at a time), the
// lattice's topology edit (beside a stroke's one-chunk re-mesh, on a second thread) and the
// re-binding and coupling of the changed vertices. Each split must give what one thread gives, bit
// for bit: the same voxels, the same surface in the same slots, the same bindings and coupled
// positions (docs/deform-cut.md, "Edit → render buffer latency").
#include <gtest/gtest.h>
#include <omp.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "support/test_data.h"
#include "tsf/common/cuda_support.h"
#include "tsf/common/error.h"
#include "tsf/crms/lattice_builders.h"
#include "tsf/interaction/tissue_model.h"
#include "tsf/io/nrrd_volume.h"
#include "tsf/volume/tissue_labels.h"
#include "tsf/volume/tool_shapes.h"

namespace tsf::interaction {
namespace {

struct EditOutcome {
  std::vector<float> density;
  std::vector<std::uint8_t> live;
  std::vector<Vec3f> positions, normals, coupled, coupled_normals;
  std::vector<std::uint8_t> labels;
  std::vector<std::array<std::uint32_t, 3>> triangles;
  std::vector<std::int32_t> cells;
  std::vector<float> w;
  std::vector<std::uint32_t> sources;
  std::size_t cut_rebound = 0;
  std::size_t cut_topology = 0;  ///< nodes deleted and springs broken by the cut
  bool cut_topology_beside_remesh = false;
  bool stroke_topology_beside_remesh = false;  ///< of the second wand stroke
  std::size_t cut_chunks_ahead = 0;  ///< of the cut's re-mesh, chunks planned ahead on the threads
  VoxelBox cut_voxels{};
  bool cut_on_device = false;
};

/// The sinus scene's kind of edits on the segmented sample with `threads` OpenMP threads: a wand
/// stroke into the nose, then a 40 mm blade swept 70 mm down through the face in its own plane.
EditOutcome edit_sample(int threads, crms::Backend backend = crms::Backend::kCpu) {
  const VoxelVolume volume = io::read_tissue_volume_nrrd(
      tsf::test::samples_dir() / "ct-head-cranium" / "segmented" / "cranium-density.nrrd");
  TissueModelOptions o;
  o.lattice.node_spacing_voxels = 2;
  o.solver.materials[0].youngs_modulus_pa = 20e3;
  o.solver.materials[0].density_g_per_mm3 = 1e-3;
  o.solver.backend = backend;
  o.anchor = [](crms::Lattice& l) {
    crms::fix_nodes_with_labels(l, {kLabelCancellousBone, kLabelCorticalBone});
  };
  const int before = omp_get_max_threads();
  omp_set_num_threads(threads);
  TissueModel model(VoxelVolume(volume), o);
  const VolumeGeometry& g = volume.geometry();

  Tool wand;
  wand.shape = collision::ToolShape::kCapsule;
  wand.radius_mm = 1.5;
  wand.half_length_mm = 1.5;
  const Rotation along_y = Rotation::about_axis({1, 0, 0}, M_PI / 2);
  const Vec3d nose = g.index_to_tissue({g.dims.x * 0.5, g.dims.y * 0.2, g.dims.z * 0.5});
  model.apply_tool(wand, {nose, along_y}, ToolMode::kAblate);
  const EditReport stroke =
      model.apply_tool(wand, {nose + Vec3d{0, 8, 0}, along_y}, ToolMode::kAblate);
  model.release_tool();

  Tool blade;
  blade.shape = collision::ToolShape::kBlade;
  blade.half_extents_mm = {20, 20, 0.5};
  const Vec3d c = g.index_to_tissue({g.dims.x * 0.5, g.dims.y * 0.3, g.dims.z * 0.5});
  model.apply_tool(blade, {c + Vec3d{0, 0, 40}, along_y}, ToolMode::kCut);
  const EditReport cut = model.apply_tool(blade, {c + Vec3d{0, 0, -30}, along_y}, ToolMode::kCut);
  omp_set_num_threads(before);

  EditOutcome out;
  out.cut_rebound = cut.vertices_rebound;
  out.cut_chunks_ahead = cut.remesh_chunks_ahead;
  out.cut_topology = cut.nodes_deleted + cut.springs_broken;
  out.cut_topology_beside_remesh = cut.topology_beside_remesh;
  out.stroke_topology_beside_remesh = stroke.edited && stroke.topology_beside_remesh;
  out.cut_voxels = cut.changed_voxels;
  out.cut_on_device = cut.edit_on_device;
  const float* d = model.volume().density_data().data();
  out.density.assign(d, d + model.volume().geometry().voxel_count());
  const imt::ImtSurface& s = model.surface();
  for (std::uint32_t v = 0; v < s.vertex_slot_count(); ++v) {
    const bool live = s.vertex_live(v);
    out.live.push_back(live ? 1 : 0);
    if (!live) continue;
    out.positions.push_back(s.positions()[v]);
    out.normals.push_back(s.normals()[v]);
    out.labels.push_back(s.labels()[v]);
    out.coupled.push_back(model.coupler().positions()[v]);
    out.coupled_normals.push_back(model.coupler().normals()[v]);
    const coupler::VertexBinding& b = model.coupler().bindings()[v];
    out.cells.push_back(b.cell);
    out.w.insert(out.w.end(), {b.w[0], b.w[1], b.w[2]});
    out.sources.push_back(model.coupler().sources()[v]);
  }
  for (std::uint32_t t = 0; t < s.triangle_slot_count(); ++t)
    out.triangles.push_back(s.triangles()[t]);
  return out;
}

TEST(EditThreads, TheSampleFaceIsCutAndAblatedAlikeOnOneAndSeveralThreads) {
  const EditOutcome one = edit_sample(1);
  // The cut must take every parallel path: a sweep long enough to share, a re-mesh over more than
  // one 32-cube chunk, more vertices to re-bind than the parallel threshold.
  ASSERT_GT(one.cut_rebound, 2048u);
  ASSERT_GT(one.cut_voxels.extent().x, 40);
  EXPECT_EQ(one.cut_chunks_ahead, 0u);
  // ... and a topology edit, always on the calling thread: its re-mesh uses the threads. A
  // stroke's re-mesh is one chunk: from 4 threads its topology runs beside it.
  ASSERT_GT(one.cut_topology, 0u);
  EXPECT_FALSE(one.cut_topology_beside_remesh);
  EXPECT_FALSE(one.stroke_topology_beside_remesh);
  for (int threads : {2, 3, 4}) {  // 4: the re-mesh's batches plan ahead; strokes' topology beside
    const EditOutcome many = edit_sample(threads);
    SCOPED_TRACE(std::to_string(threads) + " threads");
    EXPECT_EQ(many.cut_rebound, one.cut_rebound);
    EXPECT_EQ(many.cut_topology, one.cut_topology);
    EXPECT_FALSE(many.cut_topology_beside_remesh);
    EXPECT_EQ(many.stroke_topology_beside_remesh, threads >= 4);
    if (threads == 4) {
      EXPECT_GT(many.cut_chunks_ahead, 0u) << "the cut's re-mesh did not plan ahead";
    }
    EXPECT_TRUE(many.density == one.density) << "the voxels differ";
    ASSERT_TRUE(many.live == one.live) << "the live vertex slots differ";
    EXPECT_TRUE(many.triangles == one.triangles) << "the triangles differ";
    EXPECT_TRUE(many.positions == one.positions && many.normals == one.normals &&
                many.labels == one.labels)
        << "the surface's vertices differ";
    EXPECT_TRUE(many.cells == one.cells && many.w == one.w && many.sources == one.sources)
        << "the bindings differ";
    EXPECT_TRUE(many.coupled == one.coupled && many.coupled_normals == one.coupled_normals)
        << "the coupled positions differ";
  }
}

/// The BladeSweeper contract written out on the host, serially, voxel by voxel (the reverse of
/// the stroke's own loop order, sub-step by sub-step): what the CUDA sweeper must compute.
class VoxelOrderSweeper final : public BladeSweeper {
 public:
  int calls = 0;
  void sweep(const BladeSweepPlan& plan, const VolumeGeometry& g,
             std::vector<float>& weight) override {
    ++calls;
    const VoxelBox& box = plan.box;
    const double h = plan.h;
    weight.assign(static_cast<std::size_t>(box.voxel_count()), 0.0f);
    std::size_t v = 0;
    for (int k = box.lo.z; k < box.hi.z; ++k)
      for (int j = box.lo.y; j < box.hi.y; ++j)
        for (int i = box.lo.x; i < box.hi.x; ++i, ++v) {
          const Vec3d first = g.index_to_tissue({double(box.lo.x), double(j), double(k)});
          BladeDistanceMin nearest;
          for (const BladeSweepStep& s : plan.steps)
            if (s.box.contains(i, j, k))
              nearest.add(plan.blade.half_extents,
                          blade_row_frame(s.pose, first, g.spacing.x).at(i - box.lo.x));
          const double d = nearest.distance();
          weight[v] = d < h ? falloff_weight(d, h) : 0.0f;
        }
  }
};

/// The direct form of a sweep's weights: per voxel, the largest fall-off weight over the
/// sub-steps whose box reaches it, each from blade_distance() of the voxel's own position.
std::vector<float> visit_every_sub_step(const BladeSweepPlan& plan, const VolumeGeometry& g) {
  const VoxelBox& box = plan.box;
  std::vector<float> weight(static_cast<std::size_t>(box.voxel_count()), 0.0f);
  std::size_t v = 0;
  for (int k = box.lo.z; k < box.hi.z; ++k)
    for (int j = box.lo.y; j < box.hi.y; ++j)
      for (int i = box.lo.x; i < box.hi.x; ++i, ++v)
        for (const BladeSweepStep& s : plan.steps) {
          if (!s.box.contains(i, j, k)) continue;
          const double d = blade_distance(plan.blade, s.pose,
                                          g.index_to_tissue({double(i), double(j), double(k)}));
          weight[v] = std::max(weight[v], d < plan.h ? falloff_weight(d, plan.h) : 0.0f);
        }
  return weight;
}

// The sweep's contract (each row's voxels placed from the row's first one, the smallest distance
// kept and the fall-off taken once) gives the direct form's weights: for cuts along, across and
// oblique to the blade, short and long, with a hard and a soft fall-off, and a blade that turns.
TEST(BladeSweeper, TheSmallestDistanceAlongRowsGivesTheDirectFormsWeights) {
  VolumeGeometry g;
  g.dims = {40, 36, 30};
  g.spacing = {0.9, 1.1, 1.4};
  g.origin = {-12, 3, 7};
  const Vec3d c = g.index_to_tissue({20, 18, 15});
  struct Case {
    Vec3d half, move;
    Rotation from, to;
    double falloff;
  };
  const Rotation along_y = Rotation::about_axis({1, 0, 0}, M_PI / 2);
  const Rotation oblique = Rotation::about_axis({1, 2, 3}, 0.7);
  const std::vector<Case> cases = {
      {{10, 10, 0.5}, {0, 0, -20}, along_y, along_y, -1},
      {{10, 10, 0.5}, {0, 18, 0}, along_y, along_y, -1},
      {{6, 3, 1}, {7, -5, 9}, oblique, oblique, 0.5},
      {{6, 3, 1}, {0.3, 0.2, 0.1}, oblique, oblique, 0},
      {{2, 8, 0.25}, {-14, 3, -2}, Rotation{}, Rotation{}, 2.0},
      {{10, 10, 0.5}, {2, 0, 18}, along_y, Rotation::about_axis({1, 0.3, 0}, M_PI / 3), -1},
      {{6, 3, 1}, {0, 0, 0}, oblique, Rotation::about_axis({0, 1, 1}, 2.1), 0.5},
  };
  std::size_t full = 0;  // weight 1: deeper than the fall-off inside the blade
  for (const Case& cs : cases) {
    RemovalOptions o;
    o.falloff_mm = cs.falloff;
    const BladeSweepPlan plan = plan_blade_sweep(
        g, BladeTool{cs.half}, {c - cs.move * 0.5, cs.from}, {c + cs.move * 0.5, cs.to}, o);
    VoxelOrderSweeper contract;
    std::vector<float> found;
    contract.sweep(plan, g, found);
    const std::vector<float> direct = visit_every_sub_step(plan, g);
    ASSERT_EQ(found.size(), direct.size());
    std::size_t reached = 0;
    for (std::size_t v = 0; v < found.size(); ++v) {
      ASSERT_NEAR(found[v], direct[v], 1e-6f) << "voxel " << v << " of the sweep's box";
      reached += direct[v] > 0.0f;
      full += direct[v] == 1.0f;
    }
    EXPECT_GT(reached, 100u) << "a case that reaches few voxels tests little";
  }
  EXPECT_GT(full, 100u);
}

TEST(BladeSweeper, ASweeperKeepingTheContractMakesTheStrokesOwnCut) {
  const VoxelVolume sample = io::read_tissue_volume_nrrd(
      tsf::test::samples_dir() / "ct-head-cranium" / "segmented" / "cranium-density.nrrd");
  const VolumeGeometry& g = sample.geometry();
  const BladeTool blade{{20, 20, 0.5}};
  const Rotation along_y = Rotation::about_axis({1, 0, 0}, M_PI / 2);
  const Vec3d c = g.index_to_tissue({g.dims.x * 0.5, g.dims.y * 0.3, g.dims.z * 0.5});
  const ToolPose from{c + Vec3d{0, 0, 40}, along_y}, to{c + Vec3d{0, 0, -30}, along_y};
  // The scene's cut (the blade does not turn), then one that turns the blade by 30° on its way.
  const ToolPose turned{c + Vec3d{0, 0, -30}, Rotation::about_axis({1, 0.2, 0}, M_PI / 3)};
  RemovalOptions o;
  VoxelOrderSweeper sweeper;
  for (const ToolPose* end : {&to, &turned}) {
    VoxelVolume host(sample), swept(sample);
    ToolStroke a, b;
    const VoxelBox ha = a.cut_blade(host, blade, from, *end, o);
    const VoxelBox hb = b.cut_blade(swept, blade, from, *end, o, &sweeper);
    ASSERT_GT(ha.voxel_count(), 1000);
    EXPECT_TRUE(ha == hb);
    EXPECT_TRUE(std::as_const(host).density_data() == std::as_const(swept).density_data())
        << "the voxels differ";
    EXPECT_TRUE(a.last_reached() == b.last_reached());
  }
  EXPECT_EQ(sweeper.calls, 2);
  if (!cuda_status().available) {
    try {
      (void)make_cuda_blade_sweeper();
      ADD_FAILURE() << "a CUDA blade sweeper was made without CUDA";
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find("not available"), std::string::npos) << e.what();
    }
  }
}

// On the CUDA backend the cut's blade sweep runs on the device (BladeSweeper) and the coupling of
// the re-bound vertices goes through the coupler's staging on the device: the same voxels, the
// same surface and bindings as the CPU backend's edits, bit for bit (the sweep is compiled
// without FMA, as the host's is), and the coupled positions to float rounding (the coupler's
// CUDA parity). Nothing has stepped, so both solvers hold the rest positions.
TEST(EditsOnTheDevice, TheSampleFaceIsCutAndAblatedOnCudaAsOnTheCpu) {
  if (!cuda_status().available) GTEST_SKIP() << "CUDA edits not run: " << cuda_status().reason;
  const EditOutcome cpu = edit_sample(1, crms::Backend::kCpu);
  const EditOutcome gpu = edit_sample(1, crms::Backend::kCuda);
  EXPECT_FALSE(cpu.cut_on_device);
  EXPECT_TRUE(gpu.cut_on_device);
  ASSERT_GT(cpu.cut_voxels.extent().x, 40);
  EXPECT_TRUE(gpu.cut_voxels == cpu.cut_voxels);
  EXPECT_EQ(gpu.cut_rebound, cpu.cut_rebound);
  EXPECT_TRUE(gpu.density == cpu.density) << "the voxels differ";
  ASSERT_TRUE(gpu.live == cpu.live) << "the live vertex slots differ";
  EXPECT_TRUE(gpu.triangles == cpu.triangles) << "the triangles differ";
  EXPECT_TRUE(gpu.positions == cpu.positions && gpu.normals == cpu.normals)
      << "the surface's vertices differ";
  EXPECT_TRUE(gpu.cells == cpu.cells && gpu.w == cpu.w && gpu.sources == cpu.sources)
      << "the bindings differ";
  ASSERT_EQ(gpu.coupled.size(), cpu.coupled.size());
  double worst = 0;
  for (std::size_t v = 0; v < cpu.coupled.size(); ++v)
    worst = std::max(
        worst, static_cast<double>(length(to_double(gpu.coupled[v]) - to_double(cpu.coupled[v]))));
  EXPECT_LT(worst, 1e-3) << "mm, the largest difference of a coupled position";
}

}  // namespace
}  // namespace tsf::interaction
