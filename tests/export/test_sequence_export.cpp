// Sequences: numbered files always; a glTF animation: morph targets while the topology holds,
// a node per topology switched by STEP scale keys across cuts (mesh_export.h).
#include <gtest/gtest.h>

#include <map>

#include "export_test_helpers.h"
#include "tsf/common/error.h"
#include "tsf/export/mesh_export.h"

namespace tsf::exporter {
namespace {
using namespace test;

std::vector<Vec3f> sorted(std::vector<Vec3f> v) {
  std::sort(v.begin(), v.end(), [](const Vec3f& a, const Vec3f& b) {
    return std::tie(a.x, a.y, a.z) < std::tie(b.x, b.y, b.z);
  });
  return v;
}

/// The state's positions as the file should hold them (glTF: y-up, metres).
std::vector<Vec3f> file_positions(const io::MeshSequence& s, std::size_t state) {
  const imt::SurfaceMesh mesh = state == 0 ? s.rest : io::frame_mesh(s, state - 1);
  const imt::SurfaceMesh out =
      to_output_frame(mesh, make_output_frame(s.geometry, AxisConvention::y_up, LengthUnit::metre));
  return out.positions;
}

TEST(SequenceExport, ConstantTopologyGivesNumberedFilesAndAMorphAnimation) {
  const io::MeshSequence s = squashing_sphere(3);
  const fs::path dir = tsf::test::scratch_dir("sequence");
  ExportOptions o;
  o.time_scale = 10.0;
  const ExportReport report = export_sequence(s, FrameSelection::parse("all"), dir / "t.glb", o);
  EXPECT_TRUE(report.animated) << report.animation_note;
  EXPECT_EQ(files_in(dir), (std::vector<std::string>{"t-0000.glb", "t-0001.glb", "t-0002.glb",
                                                     "t-0003.glb", "t.glb"}));

  // Numbered files hold the states as they are: state 3 is squashed to 88% in height (glTF y).
  const Imported rest = import_file(dir / "t-0000.glb");
  const Imported squashed = import_file(dir / "t-0003.glb");
  EXPECT_NEAR((squashed.hi.y - squashed.lo.y) / (rest.hi.y - rest.lo.y), 0.88, 0.01);
  EXPECT_NEAR(squashed.hi.x - squashed.lo.x, rest.hi.x - rest.lo.x, 1e-6);

  // The animated file: base = state 0, one morph target per later state, keyframes at the
  // states' times × time_scale, weights e_k at keyframe k.
  const GltfDocument doc = parse_glb(read_bytes(dir / "t.glb"));
  ASSERT_TRUE(doc.json.contains("animations"));
  const auto& animation = doc.json["animations"][0];
  EXPECT_EQ(animation["name"], "tissue-motion");
  ASSERT_EQ(animation["channels"].size(), 1u);
  EXPECT_EQ(animation["channels"][0]["target"]["path"], "weights");
  const auto& sampler = animation["samplers"][0];
  EXPECT_EQ(sampler["interpolation"], "LINEAR");
  const std::vector<float> times = read_float_accessor(doc, sampler["input"].get<std::size_t>());
  ASSERT_EQ(times.size(), 4u);
  for (std::size_t k = 0; k < 4; ++k) EXPECT_NEAR(times[k], 0.2f * static_cast<float>(k), 1e-6f);
  const std::vector<float> weights = read_float_accessor(doc, sampler["output"].get<std::size_t>());
  ASSERT_EQ(weights.size(), 4u * 3u);
  for (std::size_t k = 0; k < 4; ++k)
    for (std::size_t t = 0; t < 3; ++t)
      EXPECT_EQ(weights[k * 3 + t], (k >= 1 && t == k - 1) ? 1.0f : 0.0f);

  // One mesh whose primitives are the tissues; every primitive has the three targets. Tissue
  // border vertices are in two primitives: compare distinct positions.
  const auto& primitives = doc.json["meshes"][0]["primitives"];
  ASSERT_EQ(primitives.size(), 3u);
  for (std::size_t t = 0; t < 3; ++t) {
    std::vector<Vec3f> morphed;
    for (const auto& primitive : primitives) {
      ASSERT_EQ(primitive["targets"].size(), 3u);
      const std::vector<float> base =
          read_float_accessor(doc, primitive["attributes"]["POSITION"].get<std::size_t>());
      const std::vector<float> delta =
          read_float_accessor(doc, primitive["targets"][t]["POSITION"].get<std::size_t>());
      ASSERT_EQ(delta.size(), base.size());
      for (std::size_t i = 0; i < base.size(); i += 3)
        morphed.push_back(
            {base[i] + delta[i], base[i + 1] + delta[i + 1], base[i + 2] + delta[i + 2]});
    }
    std::vector<Vec3f> got = sorted(morphed);
    got.erase(std::unique(got.begin(), got.end()), got.end());
    const std::vector<Vec3f> want = sorted(file_positions(s, t + 1));
    ASSERT_EQ(got.size(), want.size()) << "target " << t;
    float worst = 0;
    for (std::size_t i = 0; i < got.size(); ++i) worst = std::max(worst, length(got[i] - want[i]));
    EXPECT_LT(worst, 1e-7f) << "state " << t + 1 << " = base + target " << t << " (metres)";
  }
  // assimp's importer sees the morph targets too (per tissue mesh).
  EXPECT_EQ(import_file(dir / "t.glb").anim_meshes, 3u * 3u);
}

TEST(SequenceExport, SplitLabelsAnimateEveryTissueNode) {
  const io::MeshSequence s = squashing_sphere(2);
  const fs::path dir = tsf::test::scratch_dir("sequence");
  ExportOptions o;
  o.format = ExportFormat::gltf;
  o.split_labels = true;
  const ExportReport report = export_sequence(s, FrameSelection::parse("0:2"), dir / "t.gltf", o);
  ASSERT_TRUE(report.animated);
  const std::string text = read_bytes(dir / "t.gltf");
  EXPECT_EQ(text.find(".bin\""), std::string::npos) << "the buffer is embedded, no .bin file";
  const GltfDocument doc = parse_embedded_gltf(text);
  EXPECT_EQ(doc.json["animations"][0]["channels"].size(), 3u) << "one channel per tissue node";
  EXPECT_EQ(files_in(dir).size(), 4u);
}

TEST(SequenceExport, CutsAnimateBySwitchingTopologiesWithStepScaleKeys) {
  const io::MeshSequence s = sphere_with_a_cut(2);
  const fs::path dir = tsf::test::scratch_dir("sequence");
  ExportOptions o;
  o.time_scale = 10.0;
  const ExportReport report = export_sequence(s, FrameSelection::parse("all"), dir / "t.glb", o);
  EXPECT_TRUE(report.animated) << report.animation_note;
  EXPECT_EQ(report.topology_runs, 2u);
  EXPECT_EQ(files_in(dir), (std::vector<std::string>{"t-0000.glb", "t-0001.glb", "t-0002.glb",
                                                     "t-0003.glb", "t-0004.glb", "t.glb"}));
  const Imported cut = import_file(dir / "t-0003.glb");
  EXPECT_EQ(cut.triangles.size(),
            labelled_sphere(s.geometry, 4.0, {1.0, 0.0, 0.0}).triangle_count());

  // Two nodes, one per topology: states 0-2 (morph targets for 1, 2) and states 3-4 (one for 4).
  const GltfDocument doc = parse_glb(read_bytes(dir / "t.glb"));
  const std::size_t before = node_named(doc, "states 0-2"), after = node_named(doc, "states 3-4");
  EXPECT_FALSE(doc.json["nodes"][before].contains("scale")) << "shown at time 0";
  EXPECT_EQ(doc.json["nodes"][after]["scale"], nlohmann::json({0.0, 0.0, 0.0}))
      << "hidden at time 0";
  const auto& animation = doc.json["animations"][0];
  std::map<std::size_t, std::vector<std::pair<std::vector<float>, std::vector<float>>>> scale_keys;
  std::size_t weight_channels = 0;
  for (const auto& ch : animation["channels"]) {
    const auto& sampler = animation["samplers"][ch["sampler"].get<std::size_t>()];
    const std::vector<float> in = read_float_accessor(doc, sampler["input"].get<std::size_t>());
    const std::vector<float> out = read_float_accessor(doc, sampler["output"].get<std::size_t>());
    if (ch["target"]["path"] == "scale") {
      EXPECT_EQ(sampler["interpolation"], "STEP");
      scale_keys[ch["target"]["node"].get<std::size_t>()].push_back({in, out});
    } else {
      EXPECT_EQ(ch["target"]["path"], "weights");
      EXPECT_EQ(sampler["interpolation"], "LINEAR");
      ++weight_channels;
    }
  }
  EXPECT_EQ(weight_channels, 2u) << "one per run with morph targets";
  ASSERT_EQ(scale_keys[before].size(), 1u);
  ASSERT_EQ(scale_keys[after].size(), 1u);
  // States 0-2 shown from 0 until state 3's time (0.06 s × 10), states 3-4 from then on.
  for (const auto* keys : {&scale_keys[before][0], &scale_keys[after][0]}) {
    ASSERT_EQ(keys->first.size(), 2u);
    EXPECT_EQ(keys->first[0], 0.0f);
    EXPECT_NEAR(keys->first[1], 0.6f, 1e-6f);
  }
  EXPECT_EQ(scale_keys[before][0].second, (std::vector<float>{1, 1, 1, 0, 0, 0}));
  EXPECT_EQ(scale_keys[after][0].second, (std::vector<float>{0, 0, 0, 1, 1, 1}));

  // The states before the cut alone animate with morph targets only.
  const fs::path dir2 = tsf::test::scratch_dir("sequence-before-cut");
  const ExportReport early = export_sequence(s, FrameSelection::parse("0:2"), dir2 / "t.glb", {});
  EXPECT_TRUE(early.animated);
  EXPECT_EQ(early.topology_runs, 1u);
}

TEST(SequenceExport, LastStateIsTheDefaultAndOnePathIsWritten) {
  const io::MeshSequence s = squashing_sphere(2);
  const fs::path dir = tsf::test::scratch_dir("sequence");
  ExportOptions o;
  o.format = ExportFormat::stl;
  const ExportReport report = export_sequence(s, FrameSelection{}, dir / "final.stl", o);
  EXPECT_EQ(report.states, std::vector<std::size_t>{2});
  EXPECT_EQ(files_in(dir), std::vector<std::string>{"final.stl"});
  const Imported got = import_file(dir / "final.stl");
  const Imported rest_bounds = [&] {
    export_sequence(s, FrameSelection::parse("rest"), dir / "rest.stl", o);
    return import_file(dir / "rest.stl");
  }();
  // STL keeps LPS: the squash is along z.
  EXPECT_NEAR((got.hi.z - got.lo.z) / (rest_bounds.hi.z - rest_bounds.lo.z), 0.92, 0.01);
}

TEST(SequenceExport, FormatsWithoutAnimationWriteNumberedFilesOnly) {
  const io::MeshSequence s = squashing_sphere(1);
  const fs::path dir = tsf::test::scratch_dir("sequence");
  ExportOptions o;
  o.format = ExportFormat::obj;
  const ExportReport report = export_sequence(s, FrameSelection::parse("all"), dir / "t.obj", o);
  EXPECT_FALSE(report.animated);
  EXPECT_EQ(files_in(dir),
            (std::vector<std::string>{"t-0000.mtl", "t-0000.obj", "t-0001.mtl", "t-0001.obj"}));
  EXPECT_THROW(export_sequence(s, FrameSelection::parse("2"), dir / "x.obj", o), Error);
}

}  // namespace
}  // namespace tsf::exporter
