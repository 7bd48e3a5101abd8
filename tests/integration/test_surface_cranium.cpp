// The sample cranium CT through IMT: closed manifold components, incremental edits that agree with
// a fresh build, and `tsf surface` end to end.
//
// Density comes from Hounsfield units with a linear ramp 0 -> 1 over −300 ± 100 HU (skin/air
// and soft tissue/sinus air), until the segment module supplies real densities.
#include <gtest/gtest.h>
#include <itkImage.h>
#include <itkImageFileReader.h>
#include <unistd.h>

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>
#include <string>

#include "support/test_data.h"
#include "support/tsf_process.h"
#include "tsf/import/itk_io_factories.h"
#include "tsf/import/tissue_volume_io.h"
#include "tsf/imt/extract_surface.h"
#include "tsf/imt/imt_surface.h"
#include "tsf/imt/mesh_topology.h"
#include "tsf/imt/surface_ply.h"
#include "tsf/volume/volume_edits.h"

namespace tsf {
namespace {

namespace fs = std::filesystem;

VoxelVolume cranium_density(double threshold_hu) {
  import::register_itk_io_factories();
  using Image = itk::Image<float, 3>;
  auto reader = itk::ImageFileReader<Image>::New();
  reader->SetFileName((test::samples_dir() / "ct-head-cranium" / "cranium.nrrd").string());
  reader->Update();
  const Image* im = reader->GetOutput();
  const auto size = im->GetLargestPossibleRegion().GetSize();
  VolumeGeometry g;
  g.dims = {int(size[0]), int(size[1]), int(size[2])};
  g.spacing = {im->GetSpacing()[0], im->GetSpacing()[1], im->GetSpacing()[2]};
  g.origin = {im->GetOrigin()[0], im->GetOrigin()[1], im->GetOrigin()[2]};
  VoxelVolume v(g);
  const float* hu = im->GetBufferPointer();
  float* d = v.density_for_tracked_write();
  std::uint8_t* l = v.labels_for_tracked_write();
  for (std::size_t i = 0; i < v.voxel_count(); ++i) {
    d[i] = static_cast<float>(std::clamp(0.5 + (double(hu[i]) - threshold_hu) / 200.0, 0.0, 1.0));
    l[i] = d[i] >= 0.5f ? kLabelSoftTissue : kLabelOutside;
  }
  v.mark_all_modified();
  return v;
}

void expect_closed_orientable_components(const imt::SurfaceMesh& m, const std::string& what) {
  const imt::MeshTopology t = imt::analyse_topology(m);
  EXPECT_TRUE(t.closed_oriented_manifold())
      << what << ": boundary " << t.boundary_edges << " non-manifold edges " << t.nonmanifold_edges
      << " misoriented " << t.misoriented_edges << " pinched vertices " << t.nonmanifold_vertices
      << " unused " << t.unreferenced_vertices;
  ASSERT_GT(t.components, 0u);
  // Closed orientable surfaces have χ = 2 − 2·genus: even, at most 2.
  for (long chi : t.component_euler) {
    EXPECT_EQ(chi % 2, 0) << what;
    EXPECT_LE(chi, 2) << what;
  }
  EXPECT_GT(t.component_triangles[0], m.triangle_count() / 2) << what << ": the head dominates";
}

TEST(SurfaceCranium, SurfacesToClosedManifoldComponents) {
  const VoxelVolume v = cranium_density(-300.0);
  for (float eps : {0.0f, 0.1f}) {
    imt::SurfaceOptions o;
    o.snap_epsilon = eps;
    const imt::SurfaceMesh m = imt::extract_surface(v, o);
    EXPECT_GT(m.triangle_count(), 500000u);
    expect_closed_orientable_components(m, "cranium eps " + std::to_string(eps));
  }
}

TEST(SurfaceCranium, BoneThresholdAlsoGivesClosedManifolds) {
  const VoxelVolume v = cranium_density(400.0);  // thin, noisy bone: the hard case for merging
  const imt::SurfaceMesh m = imt::extract_surface(v);
  expect_closed_orientable_components(m, "cranium bone");
}

TEST(SurfaceCranium, EditsOnTheCraniumMatchAFreshBuild) {
  VoxelVolume v = cranium_density(-300.0);
  imt::ImtSurface s;
  s.build(v);
  std::mt19937 rng(17);
  std::uniform_real_distribution<double> u(0, 1);
  const auto& g = v.geometry();
  for (int i = 0; i < 60; ++i) {
    // Tools centred on surface vertices, so every edit cuts tissue.
    std::uint32_t slot = 1 + static_cast<std::uint32_t>(u(rng) * (s.vertex_slot_count() - 2));
    while (!s.vertex_live(slot)) slot = 1 + (slot % (s.vertex_slot_count() - 1));
    const Vec3d c = to_double(s.positions()[slot]);
    VoxelBox changed;
    if (i % 2 == 0)
      changed = ablate_sphere(v, {c, 1.0 + 6.0 * u(rng)});
    else
      changed = cut_swept_blade(v, {{8, 4, 0.4}}, {c, Rotation::about_axis({u(rng), 1, 0}, 1)},
                                {c + Vec3d{0, 0, 6}, Rotation::about_axis({u(rng), 1, 0}, 1.2)});
    s.update(v, changed);
  }
  s.check_invariants();
  const imt::SurfaceMesh inc = s.compact();
  const imt::SurfaceMesh full = imt::extract_surface(v);
  EXPECT_EQ(inc.triangle_count(), full.triangle_count());
  EXPECT_EQ(inc.vertex_count(), full.vertex_count());
  (void)g;
  expect_closed_orientable_components(inc, "cranium after 60 edits");
}

TEST(SurfaceCranium, CommandWritesAMeshAndStats) {
  const fs::path exe = test::tsf_executable_path();
  if (!fs::exists(exe)) GTEST_SKIP() << "not run: the tsf executable is not built at " << exe;
  const fs::path dir = test::scratch_dir("surface-cli");
  import::write_tissue_volume(dir / "cranium", cranium_density(-300.0));
  const fs::path out = dir / "cranium.ply";
  const std::string cmd = exe.string() + " surface " + (dir / "cranium-density.nrrd").string() +
                          " -o " + out.string() + " --stats --smooth 2 > " +
                          (dir / "stats.json").string();
  ASSERT_EQ(std::system(cmd.c_str()), 0) << cmd;
  std::ifstream f(dir / "stats.json");
  const nlohmann::json j = nlohmann::json::parse(f);
  const imt::SurfaceMesh m = imt::read_surface_ply(out);
  EXPECT_EQ(j.at("vertices").get<std::size_t>(), m.vertex_count());
  EXPECT_EQ(j.at("triangles").get<std::size_t>(), m.triangle_count());
  EXPECT_TRUE(j.at("closed_manifold").get<bool>());
  EXPECT_GT(j.at("times_s").at("surface").get<double>(), 0.0);

  // Bad input: a non-PLY output name is refused and nothing is written.
  const fs::path bad = dir / "cranium.obj";
  const std::string bad_cmd = exe.string() + " surface " + (dir / "cranium-density.nrrd").string() +
                              " -o " + bad.string() + " 2> " + (dir / "err.txt").string();
  EXPECT_NE(std::system(bad_cmd.c_str()), 0);
  EXPECT_FALSE(fs::exists(bad));
  std::ifstream e(dir / "err.txt");
  std::stringstream err;
  err << e.rdbuf();
  EXPECT_NE(err.str().find(".ply"), std::string::npos) << err.str();
}

}  // namespace
}  // namespace tsf
