// What edits lead to, through the commands a user runs: tearing that opens the tissue through
// every layer (`tsf simulate scenes/tear-mucosa.yaml`), tissue-dependent removal rates (mucosa
// faster than bone by the configured ratio), and exposure events when an edit comes near a vessel
// (`tsf simulate scenes/exposure-vessel.yaml`), with the scene errors of their keys.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include <filesystem>
#include <fstream>
#include <functional>
#include <string>
#include <vector>

#include "support/test_data.h"
#include "support/tsf_process.h"
#include "tsf/imt/mesh_topology.h"
#include "tsf/imt/surface_ply.h"

namespace tsf {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

/// `tsf simulate SCENE --out DIR --backend cpu`; the report (the scene's outputs.report).
json simulate(const fs::path& exe, const fs::path& scene, const fs::path& out,
              test::ProcessRun* run = nullptr) {
  const test::ProcessRun p =
      test::run_tsf(exe, "simulate " + test::shell_quoted(scene) + " --backend cpu --out " +
                             test::shell_quoted(out));
  if (run) *run = p;
  EXPECT_EQ(p.status, 0) << p.output;
  if (p.status != 0 || !fs::exists(out / "report.json")) return json();
  return json::parse(test::read_text(out / "report.json"));
}

TEST(TearScene, TheMucosaStripTearsIntoTwoPiecesAndTheReportCountsThem) {
  TSF_EXECUTABLE_OR_SKIP(exe);
  const fs::path out = test::scratch_dir("tear-mucosa") / "out";
  test::ProcessRun run;
  const json r = simulate(exe, test::source_dir() / "scenes" / "tear-mucosa.yaml", out, &run);
  ASSERT_TRUE(r.is_object());
  // The report counts the tear: springs torn, pieces of the lattice and of the surface.
  EXPECT_GT(r["totals"]["springs_torn"].get<int>(), 0);
  EXPECT_GE(r["totals"]["nodes_masked"].get<int>(), 0);
  EXPECT_GT(r["totals"]["tear_cleared_mm3"].get<double>(), 0.0);
  EXPECT_FALSE(r["tears"].empty());
  EXPECT_EQ(r["lattice"]["components_start"].get<int>(), 1);
  EXPECT_EQ(r["lattice"]["components_end"].get<int>(), 2);
  EXPECT_EQ(r["surface"]["components_end"].get<int>(), 2);
  EXPECT_TRUE(r["surface"]["closed_manifold_end"].get<bool>());
  // The final mesh on disk is those two closed pieces; the summary line says it.
  const imt::SurfaceMesh final_mesh = imt::read_surface_ply(out / "final.ply");
  const imt::MeshTopology t = imt::analyse_topology(final_mesh);
  EXPECT_EQ(t.components, 2u);
  EXPECT_TRUE(t.closed_oriented_manifold());
  EXPECT_NE(run.output.find("springs torn"), std::string::npos) << run.output;
  EXPECT_NE(run.output.find("lattice 1 → 2 pieces"), std::string::npos) << run.output;
}

/// A 30 × 12 × 12 mm block whose half y < 6 is mucosa and y > 6 cortical bone, a ball dragged
/// along the interface; `rates` is the tissue.removal.rates value.
std::string two_tissue_scene(const std::string& rates) {
  return R"(name: rates
lattice:
  source: box
  size: [30, 12, 12]
  spacing: 2
  paint:
    - {label: mucosa, box: {min: [-5, -5, -5], max: [35, 5.9, 17]}}
    - {label: cortical-bone, box: {min: [-5, 6.1, -5], max: [35, 17, 17]}}
material: {youngs_modulus: 30000, viscosity: 2, density: 0.001}
solver: {integrator: symplectic-euler, backend: cpu, dt: auto}
anchors:
  - box: {min: [-1, -1, -1], max: [31, 13, 1]}
tissue:
  voxels_per_node: 2
  removal:
    rates: )" +
         rates + R"(
tools:
  - {name: ball, shape: sphere, radius: 2.5}
script:
  frame_rate: 500
  duration: 0.02
  trajectories:
    - tool: ball
      keyframes:
        - {time: 0.0, position: [6, 6, 6], mode: ablate}
        - {time: 0.016, position: [24, 6, 6], mode: ablate}
outputs:
  report: report.json
)";
}

double removed(const json& r, const std::string& label) {
  return r["totals"]["removed_by_label_mm3"].value(label, 0.0);
}

TEST(RemovalRateScene, MucosaIsAblatedFasterThanBoneByTheConfiguredRatio) {
  TSF_EXECUTABLE_OR_SKIP(exe);
  const fs::path dir = test::scratch_dir("removal-rates");
  // The library's rates (mucosa 1, cortical bone 0.05) and a scene's own (bone 0.4).
  struct Case {
    std::string rates;
    double ratio;
  };
  for (const Case& c : {Case{"library", 0.05}, Case{"{mucosa: 1, cortical-bone: 0.4}", 0.4}}) {
    const std::string tag = c.rates == "library" ? "library" : "scene";
    std::ofstream(dir / (tag + ".yaml")) << two_tissue_scene(c.rates);
    const json r = simulate(exe, dir / (tag + ".yaml"), dir / ("out-" + tag));
    ASSERT_TRUE(r.is_object()) << tag;
    const double mucosa = removed(r, "mucosa"), bone = removed(r, "cortical-bone");
    ASSERT_GT(mucosa, 50.0) << tag;
    EXPECT_NEAR(bone / mucosa, c.ratio, 0.1 * c.ratio)
        << tag << ": mucosa " << mucosa << " mm³, bone " << bone << " mm³";
    // The effective rates: removed / reached per label.
    const json& reached = r["totals"]["reached_by_label_mm3"];
    EXPECT_NEAR(mucosa / reached.value("mucosa", 0.0), 1.0, 0.01) << tag;
    EXPECT_NEAR(bone / reached.value("cortical-bone", 0.0), c.ratio, 0.01 * c.ratio) << tag;
    EXPECT_EQ(r["session"]["removal"]["ablation_rates"].value("cortical-bone", 1.0), c.ratio)
        << tag;
  }
}

TEST(ExposureScene, AnEditNearTheVesselRaisesAnEventAtTheRightTimeAndFiresItsTrigger) {
  TSF_EXECUTABLE_OR_SKIP(exe);
  const fs::path out = test::scratch_dir("exposure-vessel") / "out";
  test::ProcessRun run;
  const json r = simulate(exe, test::source_dir() / "scenes" / "exposure-vessel.yaml", out, &run);
  ASSERT_TRUE(r.is_object());
  ASSERT_FALSE(r["exposures"].empty()) << r.dump(1).substr(0, 2000);
  const json& first = r["exposures"][0];
  // The ball (radius 2) moves 1 mm per 5 ms frame along x from -3 at t = 0; the vessel's voxels
  // nearest it lie at x = 24.5, the removed voxels reach x_ball + 1.94: tissue within 2 mm of the
  // vessel (x ≥ 22.5) is first removed at x_ball = 21, t = 0.12 s.
  EXPECT_NEAR(first["time_s"].get<double>(), 0.12, 0.0051);
  EXPECT_EQ(first["label_name"], "vessel");
  EXPECT_EQ(first["tool"], "ball");
  EXPECT_TRUE(first["first"].get<bool>());
  EXPECT_LE(first["distance_mm"].get<double>(), 2.0 + 1e-9);
  EXPECT_GT(first["distance_mm"].get<double>(), 1.0);
  // Closer approaches follow, down to the vessel itself; the trigger fired once.
  const json& last = r["exposures"].back();
  EXPECT_EQ(last["distance_mm"].get<double>(), 0.0);
  EXPECT_EQ(r["triggers_fired"], json::array({"vessel-exposed"}));
  EXPECT_EQ(r["totals"]["exposure_events"].get<std::size_t>(), r["exposures"].size());
  EXPECT_NE(run.output.find("warning: vessel exposed"), std::string::npos) << run.output;
  // The block lost more soft tissue than vessel, per voxel swept (vessel rate 0.8).
  EXPECT_GT(r["totals"]["removed_by_label_mm3"].value("soft-tissue", 0.0),
            r["totals"]["removed_by_label_mm3"].value("vessel", 0.0));
}

/// A text edit of a file (`from` → `to`) and the error the command must give for it.
struct Refusal {
  std::string from, to, expect;
};

/// For each refusal: `base` with the edit written to DIR/NAME<i>.yaml, `command` (given that
/// file's quoted path) run, which must fail naming `expect`.
void expect_refusals(const fs::path& exe, const std::string& base,
                     const std::vector<Refusal>& cases, const fs::path& dir,
                     const std::string& name,
                     const std::function<std::string(const std::string&)>& command) {
  int i = 0;
  for (const Refusal& c : cases) {
    std::string text = base;
    const auto at = text.find(c.from);
    ASSERT_NE(at, std::string::npos) << c.from;
    text.replace(at, c.from.size(), c.to);
    const fs::path file = dir / (name + std::to_string(i++) + ".yaml");
    std::ofstream(file) << text;
    const test::ProcessRun p = test::run_tsf(exe, command(test::shell_quoted(file)));
    EXPECT_NE(p.status, 0) << c.to;
    EXPECT_NE(p.output.find(c.expect), std::string::npos)
        << "expected '" << c.expect << "' in: " << p.output.substr(0, 800);
  }
}

TEST(EditConsequenceKeys, ErrorsNameTheirKeyPath) {
  TSF_EXECUTABLE_OR_SKIP(exe);
  const fs::path dir = test::scratch_dir("edit-keys");
  const std::string base = two_tissue_scene("library");
  const std::vector<Refusal> cases = {
      {"rates: library", "rates: fastest", "tissue.removal.rates: expected `library`"},
      {"rates: library", "rates: {mucosa: 2}",
       "tissue.removal.rates.mucosa: expected a number in [0, 1]"},
      {"rates: library", "rates: {gristle: 0.5}", "tissue.removal.rates.gristle"},
      {"rates: library", "rates: {mucosa: {ablate: 0.5, drill: 1}}",
       "tissue.removal.rates.mucosa.drill: unknown key"},
      {"rates: library", "rates: library\n    feather_force_mn: -1",
       "tissue.removal.feather_force_mn: expected a number in (0, 1e+06]"},
      {"rates: library", "rates: library\n  exposure: {labels: [vessel]}",
       "tissue.exposure.distance_mm: is required"},
      {"{label: mucosa, box:", "{label: mucosa, sphere:", "lattice.paint[0].sphere: unknown key"},
      {"rates: library",
       "rates: library\neffects:\n  palette: {materials: [{name: soft, youngs_modulus: 1000}]}\n"
       "  animation:\n    exposure_triggers: [{name: x, label: vessel, entry: soft}]",
       "exposure_triggers[0]: fires when an edit exposes label 'vessel', which "
       "tissue.exposure does not watch"},
  };
  expect_refusals(exe, base, cases, dir, "case", [&](const std::string& scene) {
    return "simulate -q " + scene + " --out " + test::shell_quoted(dir / "out");
  });
}

TEST(LibraryRemovalRates, TheLibraryListsThemAndBadEntriesNameTheirKeyPath) {
  TSF_EXECUTABLE_OR_SKIP(exe);
  const test::ProcessRun ok = test::run_tsf(exe, "run --materials");
  ASSERT_EQ(ok.status, 0) << ok.output;
  EXPECT_NE(ok.output.find("| cortical-bone | 0.05 | 0 | assumption:"), std::string::npos)
      << ok.output;
  const std::string library = test::read_text(test::source_dir() / "materials" / "tissues.yaml");
  const fs::path dir = test::scratch_dir("removal-library");
  const std::vector<Refusal> cases = {
      {"  cortical-bone:\n    ablation: 0.05", "  cortical-bone:\n    ablation: 1.5",
       "removal_rates.cortical-bone.ablation: expected a number in [0, 1]"},
      {"    assumption: \"compact bone", "    notes: \"compact bone",
       "removal_rates.cortical-bone.notes: unknown key"},
      {"  nerve:\n", "  2:\n", "names the same tissue label as 'mucosa'"},
  };
  expect_refusals(exe, library, cases, dir, "library",
                  [](const std::string& file) { return "run --materials --library " + file; });
}

}  // namespace
}  // namespace tsf
