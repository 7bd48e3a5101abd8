// Several tissue instances per scene (`tissues:`, app/scene/scene.h) and effects on demand, end to
// end through `tsf run`: schema errors inside an instance name their key path; a two-instance run
// writes valid outputs per instance (closed surfaces, finite energies) at the resolutions asked
// for; the same tissue at a coarser spacing really has fewer nodes; the shipped effects pair
// differs only in `effects:`, and each run reports the effects it ran and what they cost.
#include <gtest/gtest.h>
#include <unistd.h>

#include <nlohmann/json.hpp>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
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

using test::read_text;
using CommandResult = test::ProcessRun;
inline CommandResult run_command(const std::string& command, const fs::path& log) {
  return test::run_logged(command, log);
}

/// A copy of a shipped scene with text replaced, written into scenes/ of a scratch tree that
/// links the sample data, so the scene's `../data-samples/...` CT path still resolves.
fs::path edited_scene(const std::string& shipped, const std::string& name,
                      const std::vector<std::pair<std::string, std::string>>& edits) {
  std::string text = read_text(test::source_dir() / "scenes" / shipped);
  for (const auto& [from, to] : edits) {
    const auto at = text.find(from);
    EXPECT_NE(at, std::string::npos) << from;
    if (at != std::string::npos) text.replace(at, from.size(), to);
  }
  const fs::path root = test::scratch_dir("scene-instances-tree");
  std::error_code ec;
  if (!fs::exists(root / "data-samples"))
    fs::create_directory_symlink(test::samples_dir(), root / "data-samples", ec);
  fs::create_directories(root / "scenes");
  const fs::path path = root / "scenes" / (name + ".yaml");
  std::ofstream(path) << text;
  return path;
}

/// `tsf run` into `out` (new or empty: a run's folder holds only what the run wrote); the log goes
/// beside it.
CommandResult tsf_run(const fs::path& scene, const fs::path& out, const std::string& extra) {
  return run_command(test::tsf_executable_path().string() + " run " + scene.string() +
                         " -q --backend cpu " + extra + " -o " + out.string(),
                     out.parent_path() / (out.filename().string() + ".log"));
}

#define TSF_NEED_EXECUTABLE()                   \
  if (!fs::exists(test::tsf_executable_path())) \
  GTEST_SKIP() << "not run: the tsf executable is not built at " << test::tsf_executable_path()

TEST(SceneInstancesRobustness, ErrorsInsideAnInstanceNameTheKeyPath) {
  TSF_NEED_EXECUTABLE();
  struct Case {
    std::string name, from, to, expected;
  };
  const Case cases[] = {
      {"duplicate-name", "  - name: bone", "  - name: soft",
       "tissues[1].name: 'soft' is used twice"},
      {"unknown-key", "    material: cancellous_bone", "    materal: cancellous_bone",
       "tissues[1].materal: unknown key"},
      {"bad-spacing", "      node_spacing_mm: 4 ", "      node_spacing_mm: -1 ",
       "tissues[1].lattice.node_spacing_mm: "},
      {"both-spacings", "      node_spacing_mm: 4 ",
       "      node_spacing_voxels: 2\n      node_spacing_mm: 4 ",
       "tissues[1].lattice.node_spacing_mm: give node_spacing_mm or node_spacing_voxels, not both"},
      {"bad-label", "labels: [cancellous-bone, cortical-bone]", "labels: [cancellous-bone, bone]",
       "tissues[1].lattice.labels[1]: "},
      {"unknown-material", "    material: cancellous_bone", "    material: unobtainium",
       "tissues[1].material: no material 'unobtainium'"},
      {"bad-name", "  - name: bone", "  - name: bone/marrow", "tissues[1].name: expected 1 to 64"},
      {"top-level-lattice", "tissues:\n", "lattice: {source: volume}\ntissues:\n",
       "lattice: give it per instance under tissues[]"},
      {"bad-integrator", "      integrator: implicit-euler", "      integrator: leapfrog",
       "tissues[1].solver.integrator: "},
      {"empty-effects-key", "    tissue: {coupler: trilinear, deletion_threshold: 0.125}\ntools:",
       "    tissue: {coupler: trilinear, deletion_threshold: 0.125}\n    effects: {glue: {}}\n"
       "tools:",
       "tissues[1].effects.glue: unknown key"},
  };
  for (const Case& c : cases) {
    const fs::path scene = edited_scene("sinus-layers.yaml", c.name, {{c.from, c.to}});
    const CommandResult r =
        run_command(test::tsf_executable_path().string() + " run " + scene.string() + " -q",
                    scene.parent_path() / (c.name + ".log"));
    EXPECT_NE(r.status, 0) << c.name << ": " << r.output;
    EXPECT_NE(r.output.find(c.expected), std::string::npos)
        << c.name << ": expected '" << c.expected << "' in:\n"
        << r.output;
  }
}

void expect_closed_mesh(const fs::path& ply) {
  ASSERT_TRUE(fs::exists(ply)) << ply;
  const imt::SurfaceMesh m = imt::read_surface_ply(ply);
  EXPECT_GT(m.triangle_count(), 50u) << ply;
  EXPECT_TRUE(imt::analyse_topology(m).closed_oriented_manifold()) << ply;
}

void expect_finite_energy(const json& energy, const std::string& what) {
  ASSERT_FALSE(energy.empty()) << what;
  for (const auto& e : energy)
    for (const char* k : {"kinetic_nj", "elastic_nj", "gravitational_nj", "total_nj"})
      ASSERT_TRUE(std::isfinite(e[k].get<double>())) << what << ": " << e;
}

TEST(SceneInstances, TwoInstancesRunWithValidOutputsEachAtItsOwnResolution) {
  TSF_NEED_EXECUTABLE();
  const fs::path dir = test::scratch_dir("run-sinus-layers");
  const CommandResult r = tsf_run(test::source_dir() / "scenes" / "sinus-layers.yaml", dir,
                                  "--voxel-mm 2 --duration 0.012");
  ASSERT_EQ(r.status, 0) << r.output;
  const json j = json::parse(read_text(dir / "run-report.json"));
  EXPECT_TRUE(j["failure"].is_null()) << j["failure"];
  ASSERT_EQ(j["instances"].size(), 2u);
  const json& soft = j["instances"][0];
  const json& bone = j["instances"][1];
  EXPECT_EQ(soft["name"], "soft");
  EXPECT_EQ(bone["name"], "bone");
  // Node spacings in mm, whatever the voxel size: soft tissue every 2 mm, bone every 4 mm.
  EXPECT_NEAR(soft["lattice_spacing_mm"][0].get<double>(), 2.0, 1e-6);
  EXPECT_NEAR(bone["lattice_spacing_mm"][0].get<double>(), 4.0, 1e-6);
  EXPECT_EQ(soft["material"]["id"], "turbinate_soft_tissue");
  EXPECT_EQ(bone["material"]["id"], "cancellous_bone");
  // Each instance integrates as it says: soft tissue explicitly at its stable step, bone (whose
  // explicit step would be sub-microsecond) with implicit Euler at 0.5 ms.
  EXPECT_EQ(soft["integrator"], "symplectic-euler");
  EXPECT_EQ(bone["integrator"], "implicit-euler");
  EXPECT_DOUBLE_EQ(bone["dt_s"].get<double>(), 0.0005);
  EXPECT_GT(soft["steps"].get<double>(), bone["steps"].get<double>());
  EXPECT_GT(bone["fixed_nodes"].get<int>(), 0);
  for (const json& in : j["instances"]) {
    const std::string name = in["name"];
    EXPECT_GT(in["alive_nodes_start"].get<int>(), 10) << name;
    expect_finite_energy(in["energy"], name);
    expect_closed_mesh(dir / ("sinus-layers-rest-" + name + ".ply"));
    expect_closed_mesh(dir / ("sinus-layers-final-" + name + ".ply"));
    EXPECT_TRUE(in["effect_cost"].is_object()) << name;
  }
  expect_finite_energy(j["energy"], "scene total");
  // The report has a row per instance.
  const std::string md = read_text(dir / "run-report.md");
  EXPECT_NE(md.find("## Tissue instances"), std::string::npos);
  EXPECT_NE(md.find("| soft |"), std::string::npos);
  EXPECT_NE(md.find("| bone |"), std::string::npos);
}

TEST(SceneInstances, TheSameTissueAtACoarserSpacingHasFewerNodes) {
  TSF_NEED_EXECUTABLE();
  // Both instances take the soft tissue, one at 4 and one at 8 mm per node: 8× fewer cells,
  // so between 3× and 16× fewer nodes (the surface layer keeps partly filled cells).
  const fs::path scene =
      edited_scene("sinus-layers.yaml", "same-tissue-two-spacings",
                   {{"labels: [cancellous-bone, cortical-bone]",
                     "labels: [soft-tissue, mucosa, fat, cartilage]"},
                    {"    material: cancellous_bone", "    material: turbinate_soft_tissue"},
                    {"      node_spacing_mm: 2\n", "      node_spacing_mm: 4\n"},
                    {"      node_spacing_mm: 4 ", "      node_spacing_mm: 8 "}});
  const fs::path dir = test::scratch_dir("run-two-spacings");
  const CommandResult r = tsf_run(scene, dir, "--voxel-mm 2 --duration 0.002");
  ASSERT_EQ(r.status, 0) << r.output;
  const json j = json::parse(read_text(dir / "run-report.json"));
  ASSERT_EQ(j["instances"].size(), 2u);
  const double fine = j["instances"][0]["alive_nodes_start"].get<double>();
  const double coarse = j["instances"][1]["alive_nodes_start"].get<double>();
  ASSERT_GT(coarse, 0.0);
  EXPECT_GT(fine / coarse, 3.0) << fine << " vs " << coarse;
  EXPECT_LT(fine / coarse, 16.0) << fine << " vs " << coarse;
}

TEST(SceneInstances, SimulateRunsBoxInstancesAndWritesEachOnesOutputs) {
  TSF_NEED_EXECUTABLE();
  // No pipeline: two box lattices (inline and library material, 2 and 1 mm spacing) side by
  // side, a blade cutting through both. `tsf simulate` writes X-<instance>.ply per instance.
  const fs::path dir = test::scratch_dir("simulate-two-boxes");
  const fs::path scene = dir / "two-boxes.yaml";
  std::ofstream(scene) << R"(name: two-boxes
solver: {dt: auto}
tissues:
  - name: coarse
    lattice: {source: box, size: [12, 8, 8], spacing: 2, origin: [0, 0, 0]}
    material: {youngs_modulus: 50000, viscosity: 5, density: 0.001}
    anchors: [{box: {min: [-1, -1, -1], max: [1, 9, 9]}}]
  - name: fine
    lattice: {source: box, size: [12, 8, 8], spacing: 1, origin: [0, 10, 0]}
    material: fat
    anchors: [{box: {min: [-1, 9, -1], max: [1, 19, 9]}}]
    tissue: {voxels_per_node: 2}
tools:
  - {name: scalpel, shape: blade, size: [30, 30, 1]}
script:
  frame_rate: 200
  duration: 0.02
  events:
    - time: 0.005           # thickness along x: rotated a quarter turn about y
      tool: scalpel
      mode: cut
      from: {position: [8, 9, 24], rotation: {axis: [0, 1, 0], angle_deg: 90}}
      to: {position: [8, 9, -14], rotation: {axis: [0, 1, 0], angle_deg: 90}}
outputs: {mesh: out.ply, rest_mesh: rest.ply, report: report.json}
)";
  const CommandResult r =
      run_command(test::tsf_executable_path().string() + " simulate " + scene.string() +
                      " --backend cpu --out " + (dir / "out").string(),
                  dir / "log.txt");
  ASSERT_EQ(r.status, 0) << r.output;
  // The scene's outputs are names inside the output folder.
  const json j = json::parse(read_text(dir / "out" / "report.json"));
  ASSERT_EQ(j["instances"].size(), 2u);
  for (const std::string name : {"coarse", "fine"}) {
    expect_closed_mesh(dir / "out" / ("out-" + name + ".ply"));
    expect_closed_mesh(dir / "out" / ("rest-" + name + ".ply"));
  }
  const json& coarse = j["instances"][0];
  const json& fine = j["instances"][1];
  EXPECT_NEAR(coarse["lattice"]["spacing_mm"][0].get<double>(), 2.0, 1e-9);
  EXPECT_NEAR(fine["lattice"]["spacing_mm"][0].get<double>(), 1.0, 1e-9);
  // Same box size, half the spacing: (12+1)(8+1)(8+1) vs (6+1)(4+1)(4+1) nodes.
  EXPECT_GT(fine["lattice"]["alive_nodes_start"].get<double>(),
            4.0 * coarse["lattice"]["alive_nodes_start"].get<double>());
  EXPECT_EQ(fine["material"]["id"], "fat");
  // The blade sweeps through both boxes: both were edited.
  EXPECT_GT(coarse["totals"]["edits"].get<int>(), 0);
  EXPECT_GT(fine["totals"]["edits"].get<int>(), 0);
}

/// The scene's lines without comments and without its top-level `effects:` block.
std::vector<std::string> lines_without_effects(const fs::path& file, bool& had_effects) {
  std::istringstream in(read_text(file));
  std::vector<std::string> out;
  bool in_effects = false;
  had_effects = false;
  for (std::string line; std::getline(in, line);) {
    const auto hash = line.find('#');
    if (hash != std::string::npos) line.erase(hash);
    while (!line.empty() && line.back() == ' ') line.pop_back();
    if (line.empty()) continue;
    const bool top_level = line[0] != ' ' && line[0] != '-';
    if (top_level) in_effects = line.rfind("effects:", 0) == 0;
    if (in_effects) {
      had_effects = true;
      continue;
    }
    out.push_back(line);
  }
  return out;
}

TEST(EffectsPair, TheTwoSinusScenesDifferOnlyInTheirEffectsSection) {
  bool plain_effects = false, effects_effects = false;
  const auto plain =
      lines_without_effects(test::source_dir() / "scenes" / "sinus.yaml", plain_effects);
  const auto with =
      lines_without_effects(test::source_dir() / "scenes" / "sinus-effects.yaml", effects_effects);
  EXPECT_FALSE(plain_effects) << "sinus.yaml is the pair's no-effects half";
  EXPECT_TRUE(effects_effects) << "sinus-effects.yaml must have an effects: section";
  EXPECT_EQ(plain, with);
}

TEST(EffectsPair, EachRunReportsTheEffectsItRanAndTheirCost) {
  TSF_NEED_EXECUTABLE();
  for (const std::string name : {"sinus", "sinus-effects"}) {
    const fs::path dir = test::scratch_dir("run-pair-" + name);
    const CommandResult r = tsf_run(test::source_dir() / "scenes" / (name + ".yaml"), dir,
                                    "--voxel-mm 2 --duration 0.012");
    ASSERT_EQ(r.status, 0) << r.output;
    const json j = json::parse(read_text(dir / "run-report.json"));
    EXPECT_EQ(j["scene"]["name"], name);
    const json& in = j["instances"][0];
    const json& configs = in["effect_cost"]["configurations"];
    ASSERT_GE(configs.size(), 2u);
    // "off" and "off again" are the same configuration: same bytes per node.
    EXPECT_EQ(configs[0]["bytes_per_node"], configs[1]["bytes_per_node"]);
    for (const json& c : configs) EXPECT_GT(c["median_us_per_step"].get<double>(), 0.0) << c;
    const std::string md = read_text(dir / "run-report.md");
    if (name == "sinus") {
      // No effects section: only the volumetric term of the library tissue's ν (a material
      // property), measured against ν = 0.
      EXPECT_EQ(j["effects_active"], json::array({"volumetric"})) << j["effects_active"];
      EXPECT_EQ(configs.size(), 3u);
      EXPECT_EQ(configs[2]["name"], "volumetric");
      EXPECT_NE(md.find("### Effect cost"), std::string::npos);
    } else {
      EXPECT_NE(md.find("### Effect cost"), std::string::npos);
      EXPECT_NE(md.find("Noise band"), std::string::npos);
      const std::vector<std::string> expected = {"anisotropy", "fluid", "plasticity", "tearing",
                                                 "volumetric"};
      EXPECT_EQ(j["effects_active"].get<std::vector<std::string>>(), expected);
      // Off, off again, all five, each alone.
      EXPECT_EQ(configs.size(), 8u);
      // Plasticity and fluid keep per-node arrays: the effects cost memory.
      EXPECT_GT(configs[2]["bytes_per_node"].get<double>(),
                configs[0]["bytes_per_node"].get<double>());
    }
  }
}

}  // namespace
}  // namespace tsf
