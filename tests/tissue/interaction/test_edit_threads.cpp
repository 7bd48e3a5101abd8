// The edit path shares its work among the OpenMP threads: the blade sweep's sub-steps, the IMT
// re-mesh's lattice windows, vertex tables and refresh plans (a batch of chunks at a time) and
// the re-binding and coupling of the changed vertices. Each split must give what one thread gives,
// bit for bit: the same voxels, the same surface in the same slots, the same bindings and coupled
// positions (docs/deform-cut.md, "Edit → render buffer latency").
#include <gtest/gtest.h>
#include <omp.h>

#include <array>
#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include "support/test_data.h"
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
  VoxelBox cut_voxels{};
};

/// The sinus scene's kind of edits on the segmented sample with `threads` OpenMP threads: a wand
/// stroke into the nose, then a 40 mm blade swept 70 mm down through the face in its own plane.
EditOutcome edit_sample(int threads) {
  const VoxelVolume volume = io::read_tissue_volume_nrrd(
      tsf::test::samples_dir() / "ct-head-cranium" / "segmented" / "cranium-density.nrrd");
  TissueModelOptions o;
  o.lattice.node_spacing_voxels = 2;
  o.solver.materials[0].youngs_modulus_pa = 20e3;
  o.solver.materials[0].density_g_per_mm3 = 1e-3;
  o.solver.backend = crms::Backend::kCpu;
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
  out.cut_voxels = cut.changed_voxels;
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
  for (int threads : {2, 3, 4}) {  // 4: the re-mesh's batches work ahead (kAheadChunks)
    const EditOutcome many = edit_sample(threads);
    SCOPED_TRACE(std::to_string(threads) + " threads");
    EXPECT_EQ(many.cut_rebound, one.cut_rebound);
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

}  // namespace
}  // namespace tsf::interaction
