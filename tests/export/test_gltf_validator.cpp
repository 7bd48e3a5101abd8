// glTF and GLB output passes the Khronos glTF validator (tools/gltf-validator, run with Node.js)
// with no errors and no warnings: a surface, per-tissue meshes, morph-target animations, levels
// of detail (MSFT_lod), tissue bodies and an animation across a cut.
#include <gtest/gtest.h>

#include <iostream>

#include "export_test_helpers.h"
#include "tsf/export/mesh_export.h"

namespace tsf::exporter {
namespace {
using namespace test;

void expect_valid(const std::string& node, const fs::path& file) {
  const nlohmann::json report = run_gltf_validator(node, file);
  ASSERT_TRUE(report.is_object()) << file;
  ASSERT_FALSE(report.contains("error")) << report.dump();
  std::cout << "[validator] " << file.filename().string() << ": " << report.dump() << "\n";
  EXPECT_EQ(report["errors"], 0) << report.dump(1);
  EXPECT_EQ(report["warnings"], 0) << report.dump(1);
}

TEST(GltfValidator, SurfaceGlbAndGltfHaveNoErrors) {
  TSF_NODE_OR_SKIP(node);
  const VolumeGeometry g = oblique_geometry();
  const imt::SurfaceMesh mesh = labelled_sphere(g);
  const fs::path dir = tsf::test::scratch_dir("validator");
  export_surface(mesh, g, dir / "surface.glb", {});
  ExportOptions o;
  o.format = ExportFormat::gltf;
  export_surface(mesh, g, dir / "surface.gltf", o);
  expect_valid(node, dir / "surface.glb");
  expect_valid(node, dir / "surface.gltf");
}

TEST(GltfValidator, SplitLabelsAndCentredHaveNoErrors) {
  TSF_NODE_OR_SKIP(node);
  const VolumeGeometry g = oblique_geometry();
  const fs::path dir = tsf::test::scratch_dir("validator");
  ExportOptions o;
  o.split_labels = true;
  o.centre = true;
  export_surface(labelled_sphere(g), g, dir / "split.glb", o);
  expect_valid(node, dir / "split.glb");
}

TEST(GltfValidator, MorphAnimationHasNoErrors) {
  TSF_NODE_OR_SKIP(node);
  io::MeshSequence s;
  s.geometry = oblique_geometry();
  s.rest = labelled_sphere(s.geometry);
  for (int f = 1; f <= 3; ++f) {
    io::MeshFrame frame;
    frame.time_s = 0.05 * f;
    for (const Vec3f& p : s.rest.positions)
      frame.positions.push_back(p + Vec3f{0.0f, 0.0f, 0.3f * static_cast<float>(f)});
    frame.normals = s.rest.normals;
    s.frames.push_back(frame);
  }
  const fs::path dir = tsf::test::scratch_dir("validator");
  for (bool split : {false, true}) {
    ExportOptions o;
    o.split_labels = split;
    const fs::path file = dir / (split ? "animated-split.glb" : "animated.glb");
    ASSERT_TRUE(export_sequence(s, FrameSelection::parse("all"), file, o).animated);
    expect_valid(node, file);
  }
}

TEST(GltfValidator, LevelsOfDetailBodiesAndCutAnimationsHaveNoErrors) {
  TSF_NODE_OR_SKIP(node);
  const VolumeGeometry g = cube_geometry({40, 40, 40}, 0.5);
  const imt::SurfaceMesh mesh = labelled_sphere(g, 8.0, {1.0, 1.0, 1.0});
  const fs::path dir = tsf::test::scratch_dir("validator");
  ExportOptions lods;
  lods.decimation = DecimationOptions{};
  lods.decimation->target_triangles = 4000;
  lods.lods = {1500, 400};
  const ExportReport r = export_surface(mesh, g, dir / "lods.glb", lods);
  ASSERT_EQ(r.levels.size(), 3u);
  expect_valid(node, dir / "lods.glb");
  lods.split_labels = true;
  export_surface(mesh, g, dir / "lods-split.glb", lods);
  expect_valid(node, dir / "lods-split.glb");

  // Bodies of a two-tissue ball (one node per body).
  VoxelVolume v(g);
  for (int k = 0; k < 40; ++k)
    for (int j = 0; j < 40; ++j)
      for (int i = 0; i < 40; ++i) {
        const double r2 =
            (i - 20.0) * (i - 20.0) + (j - 20.0) * (j - 20.0) + (k - 20.0) * (k - 20.0);
        if (r2 > 15.0 * 15.0) continue;
        v.density_data()[v.index(i, j, k)] = 1.0f;
        v.label_data()[v.index(i, j, k)] = r2 < 8.0 * 8.0 ? kLabelCorticalBone : kLabelSoftTissue;
      }
  v.mark_all_modified();
  export_bodies(v, 0.5f, dir / "bodies.glb", {});
  expect_valid(node, dir / "bodies.glb");

  // A sequence across a cut: two nodes switched by STEP scale keys.
  const io::MeshSequence s = sphere_with_a_cut(1);
  ASSERT_TRUE(export_sequence(s, FrameSelection::parse("all"), dir / "cut.glb", {}).animated);
  expect_valid(node, dir / "cut.glb");
}

TEST(GltfValidator, ValidatorCatchesABrokenAsset) {
  TSF_NODE_OR_SKIP(node);
  // The harness must be able to fail: an accessor that points past its buffer is an error.
  const VolumeGeometry g = oblique_geometry();
  const fs::path dir = tsf::test::scratch_dir("validator");
  export_surface(labelled_sphere(g), g, dir / "ok.glb", {});
  GltfDocument doc = parse_glb(read_bytes(dir / "ok.glb"));
  doc.json["accessors"][0]["count"] = doc.json["accessors"][0]["count"].get<int>() * 10;
  const std::string broken = write_glb(doc);
  std::ofstream(dir / "broken.glb", std::ios::binary)
      .write(broken.data(), static_cast<std::streamsize>(broken.size()));
  const nlohmann::json report = run_gltf_validator(node, dir / "broken.glb");
  ASSERT_TRUE(report.is_object());
  EXPECT_GT(report["errors"].get<int>(), 0) << report.dump(1);
}

}  // namespace
}  // namespace tsf::exporter
