// glTF and GLB output passes the Khronos glTF validator (tools/gltf-validator, run with Node.js)
// with no errors: a surface, per-tissue meshes, and a morph-target animation.
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
