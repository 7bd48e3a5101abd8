// Scenes placed by anatomy (app/scene/anatomy_placement.h): the shipped scenes/sinus-ci.yaml
// runs end to end on the sample cranium and on the bundled GE DICOM series, whose heads lie in
// different places of their scanners' frames and face opposite ways along y; the keys are read
// strictly, and a scene that places by anatomy without a pipeline section or a segment report
// beside its volume is refused by name.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include <filesystem>
#include <fstream>
#include <string>

#include "support/test_data.h"
#include "support/tsf_process.h"
#include "tsf/imt/mesh_topology.h"
#include "tsf/imt/surface_ply.h"

namespace tsf {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using test::read_text;
using test::shell_quoted;

fs::path anatomy_scene() {
  return test::source_dir() / "scenes" / "sinus-ci.yaml";
}

/// The crop of sinus-ci.yaml: a box placed around the nose tip.
const std::string kCenterCrop =
    "{center: {landmark: nose-tip, offset_mm: {posterior: 25, superior: 5}}, size_mm: [50, 56, "
    "60]}";

bool contains(const std::string& text, const std::string& what) {
  return text.find(what) != std::string::npos;
}

const json* named(const json& list, const std::string& name) {
  for (const json& e : list)
    if (e["name"] == name) return &e;
  return nullptr;
}

/// Runs the anatomy scene (on `ct` when given) and checks the run: completed, edits > 0, closed
/// final surface, the placement stage, and the nose tip in the segment report.
json run_anatomy_scene(const fs::path& exe, const std::string& name, const fs::path& ct) {
  const fs::path dir = test::scratch_dir("anatomy-scene-" + name);
  const fs::path out = dir / "out";
  const test::ProcessRun r = test::run_tsf(
      exe, "run " + shell_quoted(anatomy_scene()) + " -q --backend cpu --voxel-mm 2 " +
               "--duration 0.012 --force -o " + shell_quoted(out) +
               (ct.empty() ? std::string() : " --ct " + shell_quoted(ct)));
  EXPECT_EQ(r.status, 0) << r.output;
  const json run = json::parse(read_text(out / "run-report.json"));
  EXPECT_TRUE(run["failure"].is_null()) << run["failure"];
  EXPECT_GT(run["interaction"]["totals"]["edits"].get<int>(), 0);
  std::string stages;
  for (const auto& s : run["stages"]) stages += s["stage"].get<std::string>() + ";";
  EXPECT_TRUE(contains(stages, "place the scene by anatomy")) << stages;
  const fs::path ply = out / "sinus-ci-final.ply";
  EXPECT_TRUE(fs::exists(ply)) << ply;
  if (fs::exists(ply)) {
    const imt::SurfaceMesh m = imt::read_surface_ply(ply);
    EXPECT_GT(m.triangle_count(), 100u);
    EXPECT_TRUE(imt::analyse_topology(m).closed_oriented_manifold()) << ply;
  }
  const json seg = json::parse(read_text(out / "sinus-ci-report.json"));
  EXPECT_TRUE(seg.contains("anatomy"));
  const json* tip = named(seg["anatomy"]["landmarks"], "nose-tip");
  EXPECT_TRUE(tip && (*tip)["found"].get<bool>());
  return seg;
}

TEST(PatientAnatomy, SinusAnatomySceneRunsOnTheCranium) {
  TSF_EXECUTABLE_OR_SKIP(exe);
  const json seg = run_anatomy_scene(exe, "cranium", {});
  const json* tip = named(seg["anatomy"]["landmarks"], "nose-tip");
  ASSERT_NE(tip, nullptr);
  EXPECT_NEAR((*tip)["position_mm"][1].get<double>(), 232.0, 3.0);
  EXPECT_GE((*tip)["confidence"].get<double>(), 0.5);
  EXPECT_FALSE(seg["anatomy"]["facing"]["agrees_with_frame"].get<bool>());
}

TEST(PatientAnatomy, SinusAnatomySceneRunsOnTheGeSeries) {
  TSF_EXECUTABLE_OR_SKIP(exe);
  const fs::path ge = test::samples_dir() / "ct-head-ge-hispeed-tilt-varspacing";
  if (!fs::exists(ge)) GTEST_SKIP() << "not run: " << ge << " is missing";
  const json seg = run_anatomy_scene(exe, "ge", ge);
  // The GE series records its frame (LPS) and the face points toward −y, as it should.
  EXPECT_TRUE(seg["anatomy"]["orientation_recorded"].get<bool>());
  EXPECT_LT(seg["anatomy"]["directions"]["anterior"][1].get<double>(), -0.9);
}

TEST(PatientAnatomy, APhantomWithoutAFaceIsRefusedWithTheReason) {
  TSF_EXECUTABLE_OR_SKIP(exe);
  TSF_SHARED_DATA_OR_SKIP(shared);
  // A Philips head phantom: a skull with test inserts, no face. Its recorded frame and its image
  // disagree about where a face would be, and no nose protrudes: the scene is not placed on it.
  const fs::path phantom = shared / "dicom" / "ct-head-phantom-philips-ingenuity";
  const test::ProcessRun r =
      test::run_tsf(exe, "run " + shell_quoted(anatomy_scene()) + " -q --backend cpu --ct " +
                             shell_quoted(phantom) + " -o " +
                             shell_quoted(test::scratch_dir("anatomy-phantom") / "out"));
  EXPECT_NE(r.status, 0) << r.output;
  EXPECT_TRUE(contains(r.output, "'nose-tip' was not found in this CT")) << r.output;
  EXPECT_TRUE(contains(r.output, "this CT may not show a face (a phantom")) << r.output;
}

/// The anatomy scene with its CT given as an absolute path and one piece of text replaced.
fs::path anatomy_scene_copy(const fs::path& dir, const std::string& name, const std::string& from,
                            const std::string& to) {
  std::string t = read_text(anatomy_scene());
  const auto at = t.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  if (at != std::string::npos) t.replace(at, from.size(), to);
  t.replace(t.find("ct: ../data-samples/"), std::string("ct: ../").size(),
            "ct: " + test::source_dir().string() + "/");
  const fs::path scene = dir / (name + ".yaml");
  std::ofstream(scene) << t;
  return scene;
}

TEST(PatientAnatomy, ALandmarkOfLowConfidenceIsUsedAndWarnedAboutWithItsConfidence) {
  TSF_EXECUTABLE_OR_SKIP(exe);
  const fs::path dir = test::scratch_dir("anatomy-low-confidence");
  // The cranium records no left/right: its nostrils are found with confidence < 0.5.
  const fs::path scene =
      anatomy_scene_copy(dir, "low", "{landmark: nose-tip, offset_mm: {anterior: 3, inferior: 2}}",
                         "{landmark: nostril-left, offset_mm: {anterior: 8}}");
  const test::ProcessRun r =
      test::run_tsf(exe, "run " + shell_quoted(scene) + " -q --backend cpu --duration 0.004 -o " +
                             shell_quoted(dir / "out"));
  ASSERT_EQ(r.status, 0) << r.output;
  const json run = json::parse(read_text(dir / "out" / "run-report.json"));
  std::string warnings;
  for (const auto& w : run["warnings"]) warnings += w.get<std::string>() + "\n";
  EXPECT_TRUE(contains(warnings, "uses 'nostril-left', found with confidence 0.")) << warnings;
  EXPECT_TRUE(contains(warnings, "script.trajectories[1].keyframes[0].position")) << warnings;
  EXPECT_TRUE(contains(read_text(dir / "out" / "run-report.md"), "nostril-left"));
}

TEST(PatientAnatomy, ARegionNotFoundStopsTheRunNamingTheKeyAndWhy) {
  TSF_EXECUTABLE_OR_SKIP(exe);
  const fs::path dir = test::scratch_dir("anatomy-not-found");
  // At 2 mm the cranium's maxillary sinuses are not separated from the nasal cavity.
  const fs::path scene =
      anatomy_scene_copy(dir, "missing", kCenterCrop, "{region: maxillary-left, margin_mm: 12}");
  const test::ProcessRun r =
      test::run_tsf(exe, "run " + shell_quoted(scene) + " -q --backend cpu --duration 0.004 -o " +
                             shell_quoted(dir / "out"));
  EXPECT_NE(r.status, 0);
  EXPECT_TRUE(contains(r.output, "lattice.crop.region: 'maxillary-left' was not found in this CT"))
      << r.output;
  EXPECT_TRUE(contains(r.output, "not separated")) << r.output;
}

TEST(PatientAnatomy, AnatomyKeysWithoutAPipelineAreRefusedByName) {
  TSF_EXECUTABLE_OR_SKIP(exe);
  const fs::path dir = test::scratch_dir("anatomy-no-pipeline");
  const fs::path scene = dir / "no-pipeline.yaml";
  std::ofstream(scene) << "lattice:\n  source: volume\n  volume: missing-density.nrrd\n"
                          "  crop: {region: nasal-cavity, margin_mm: 10}\n"
                          "material: turbinate_soft_tissue\n";
  const test::ProcessRun r = test::run_tsf(exe, "simulate " + shell_quoted(scene));
  EXPECT_NE(r.status, 0);
  EXPECT_TRUE(contains(r.output, "lattice.crop.region")) << r.output;
  EXPECT_TRUE(contains(r.output, "missing-report.json' does not exist")) << r.output;
}

TEST(PatientAnatomy, AnatomyKeysAreReadStrictly) {
  TSF_EXECUTABLE_OR_SKIP(exe);
  const fs::path dir = test::scratch_dir("anatomy-strict");
  const std::string text = read_text(anatomy_scene());
  struct Case {
    std::string from, to, expect;
  };
  const Case cases[] = {
      {kCenterCrop, "{region: nasal-cavty, margin_mm: 12}", "lattice.crop.region"},
      {"size_mm: [50, 56, 60]", "size_mm: [50, 56, -60]", "lattice.crop.size_mm"},
      {"size_mm: [50, 56, 60]", "sizes: [50, 56, 60]", "lattice.crop.sizes"},
      {"offset_mm: {posterior: 47}", "offset_mm: {backward: 47}", "offset_mm.backward"},
      {"rotation: {axis: left, angle_deg: 90}", "rotation: {axis: leftward, angle_deg: 90}",
       "rotation.axis: expected [x, y, z] or a patient direction"},
      {"normal: anterior}", "normal: forward}", "plane.normal"},
      {"{landmark: nose-tip, offset_mm: {anterior: 3,",
       "{landmark: nose-top, offset_mm: {anterior: 3,", "unknown landmark 'nose-top'"},
  };
  int i = 0;
  for (const Case& c : cases) {
    std::string t = text;
    const auto at = t.find(c.from);
    ASSERT_NE(at, std::string::npos) << c.from;
    t.replace(at, c.from.size(), c.to);
    t.replace(t.find("ct: ../data-samples/"), std::string("ct: ../").size(),
              "ct: " + (test::source_dir()).string() + "/");
    const fs::path scene = dir / ("case" + std::to_string(i++) + ".yaml");
    std::ofstream(scene) << t;
    const test::ProcessRun r =
        test::run_tsf(exe, "run " + shell_quoted(scene) + " -q -o " + shell_quoted(dir / "out"));
    EXPECT_NE(r.status, 0) << c.to;
    EXPECT_TRUE(contains(r.output, c.expect)) << c.to << ":\n" << r.output;
  }
}

}  // namespace
}  // namespace tsf
