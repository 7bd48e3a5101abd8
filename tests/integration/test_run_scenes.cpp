// `tsf run`, end to end through the executable: the shipped CI sinus scene runs headless and
// writes valid outputs (closed-manifold meshes, a report whose plots exist, finite energy), `tsf
// run` with no scene finds the bundled sinus scene, schema errors in the pipeline section name
// their key path, and the material library prints with its derived lattice parameters.
#include <gtest/gtest.h>
#include <unistd.h>

#include <nlohmann/json.hpp>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <regex>
#include <sstream>
#include <string>

#include "support/test_data.h"
#include "support/tsf_process.h"
#include "tsf/imt/mesh_topology.h"
#include "tsf/imt/surface_ply.h"

namespace tsf {
namespace {

namespace fs = std::filesystem;

using test::read_text;
using CommandResult = test::ProcessRun;
inline CommandResult run_command(const std::string& command, const fs::path& log) {
  return test::run_logged(command, log);
}

bool is_png(const fs::path& p) {
  const std::string s = read_text(p);
  return s.size() > 8 && s.compare(0, 8, "\x89PNG\r\n\x1a\n") == 0;
}

void expect_valid_run_folder(const fs::path& dir, const std::string& name) {
  const fs::path json_path = dir / "run-report.json";
  ASSERT_TRUE(fs::exists(json_path)) << json_path;
  const nlohmann::json r = nlohmann::json::parse(read_text(json_path));
  EXPECT_TRUE(r["failure"].is_null()) << r["failure"];
  // Every stage of the pipeline is timed.
  std::string stages;
  for (const auto& s : r["stages"]) {
    stages += s["stage"].get<std::string>() + ";";
    EXPECT_GE(s["seconds"].get<double>(), 0.0) << s;
  }
  for (const char* stage : {"import", "segment", "surface + lattice", "scripted interaction"})
    EXPECT_NE(stages.find(stage), std::string::npos)
        << "missing stage " << stage << " in " << stages;
  // The simulation ran, stayed finite and the tissue was edited.
  EXPECT_GT(r["rates"]["steps"].get<double>(), 0.0);
  EXPECT_GT(r["rates"]["node_steps_per_s"].get<double>(), 0.0);
  ASSERT_FALSE(r["energy"].empty());
  for (const auto& e : r["energy"])
    for (const char* k : {"kinetic_nj", "elastic_nj", "gravitational_nj", "total_nj"})
      ASSERT_TRUE(std::isfinite(e[k].get<double>())) << e;
  EXPECT_GT(r["interaction"]["totals"]["edits"].get<int>(), 0);
  EXPECT_EQ(r["material"]["id"], "turbinate_soft_tissue");
  // Meshes: closed, consistently oriented manifolds.
  for (const std::string suffix : {"-rest.ply", "-final.ply"}) {
    const fs::path ply = dir / (name + suffix);
    ASSERT_TRUE(fs::exists(ply)) << ply;
    const imt::SurfaceMesh m = imt::read_surface_ply(ply);
    EXPECT_GT(m.triangle_count(), 100u) << ply;
    EXPECT_TRUE(imt::analyse_topology(m).closed_oriented_manifold()) << ply;
  }
  // glTF binary export when the export module is built: a GLB container (magic "glTF").
  for (const auto& e : r["exported"]) {
    const fs::path glb = dir / e.get<std::string>();
    ASSERT_TRUE(fs::exists(glb)) << glb;
    EXPECT_EQ(read_text(glb).substr(0, 4), "glTF") << glb;
  }
  // The segmented volume and the report with its plots.
  EXPECT_TRUE(fs::exists(dir / (name + "-density.nrrd")));
  const std::string md = read_text(dir / "run-report.md");
  for (const char* section : {"## Time per stage", "## Simulation rate", "## Energy over time",
                              "## Tool force", "## Effects active"})
    EXPECT_NE(md.find(section), std::string::npos) << section;
  const std::regex image(R"(!\[[^\]]*\]\(([^)]+)\))");
  int images = 0;
  for (auto it = std::sregex_iterator(md.begin(), md.end(), image); it != std::sregex_iterator();
       ++it, ++images) {
    const fs::path png = dir / (*it)[1].str();
    EXPECT_TRUE(fs::exists(png) && is_png(png)) << png;
  }
  EXPECT_GE(images, 2) << "stage and energy plots expected (gnuplot is a dependency)";
}

TEST(RunScene, TheCiSinusSceneRunsEndToEndAndItsOutputsAreValid) {
  const fs::path exe = test::tsf_executable_path();
  if (!fs::exists(exe)) GTEST_SKIP() << "not run: the tsf executable is not built at " << exe;
  const fs::path ct = test::samples_dir() / "ct-head-cranium" / "cranium.nrrd";
  ASSERT_TRUE(fs::exists(ct)) << "the sample CT ships with the repository: " << ct;
  const fs::path dir = test::scratch_dir("run-sinus-ci");
  const CommandResult r = run_command(
      exe.string() + " run " + (test::source_dir() / "scenes" / "sinus-ci.yaml").string() +
          " -q --backend cpu -o " + (dir / "out").string(),
      dir / "log.txt");
  ASSERT_EQ(r.status, 0) << r.output;
  expect_valid_run_folder(dir / "out", "sinus-ci");
  // The library's soft tissue runs with its ν (the volumetric term), and the report says so.
  const nlohmann::json j = nlohmann::json::parse(read_text(dir / "out" / "run-report.json"));
  EXPECT_DOUBLE_EQ(j["material"]["poisson_ratio"].get<double>(), 0.49);
  EXPECT_DOUBLE_EQ(j["instances"][0]["poisson_ratio"]["runs_with"].get<double>(), 0.49);
  EXPECT_EQ(j["instances"][0]["effects_active"], nlohmann::json::array({"volumetric"}));
  const std::string md = read_text(dir / "out" / "run-report.md");
  EXPECT_NE(md.find("Poisson ratio: ν = 0.49, volumetric term"), std::string::npos);
}

TEST(RunScene, WithNoSceneItRunsTheBundledSinusSceneFromTheRepositoryRoot) {
  const fs::path exe = test::tsf_executable_path();
  if (!fs::exists(exe)) GTEST_SKIP() << "not run: the tsf executable is not built at " << exe;
  const fs::path dir = test::scratch_dir("run-default");
  // No scene argument: scenes/sinus.yaml is found from the working directory (the checkout);
  // coarse voxels and a short script keep it to seconds.
  const CommandResult r = run_command("cd " + test::source_dir().string() + " && " + exe.string() +
                                          " run --voxel-mm 2 --duration 0.012 " +
                                          "--backend cpu -q -o " + (dir / "out").string(),
                                      dir / "log.txt");
  ASSERT_EQ(r.status, 0) << r.output;
  const nlohmann::json j = nlohmann::json::parse(read_text(dir / "out" / "run-report.json"));
  EXPECT_EQ(j["scene"]["name"], "sinus");
  EXPECT_TRUE(fs::exists(dir / "out" / "sinus-final.ply"));
}

/// A copy of the CI scene with one line replaced, in a scratch folder next to a copy of the CT
/// path (the scene refers to the CT relative to its own folder).
fs::path broken_scene(const std::string& name, const std::string& from, const std::string& to) {
  std::string text = read_text(test::source_dir() / "scenes" / "sinus-ci.yaml");
  const auto at = text.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  if (at != std::string::npos) text.replace(at, from.size(), to);
  const fs::path path = test::scratch_dir("run-bad-scenes") / (name + ".yaml");
  std::ofstream(path) << text;
  return path;
}

TEST(RunSceneRobustness, PipelineErrorsNameTheKeyPath) {
  const fs::path exe = test::tsf_executable_path();
  if (!fs::exists(exe)) GTEST_SKIP() << "not run: the tsf executable is not built at " << exe;
  struct Case {
    std::string name, from, to, expected;
  };
  const Case cases[] = {
      {"unknown-key", "    energy_every: 1", "    energy_evry: 1",
       "pipeline.outputs.energy_evry: unknown key"},
      {"voxel-range", "    voxel_mm: 2 ", "    voxel_mm: -2 ",
       "pipeline.segmentation.voxel_mm: expected a number in [0, 10], got -2"},
      {"bad-bool", "    meshes: true", "    meshes: maybe",
       "pipeline.outputs.meshes: expected true or false, got 'maybe'"},
      {"unknown-material", "  material: turbinate_soft_tissue", "  material: unobtainium",
       "pipeline.material: no material 'unobtainium'"},
      {"missing-ct", "    ct: ../data-samples/ct-head-cranium/cranium.nrrd", "    ct: nowhere.nrrd",
       "pipeline.source.ct: '"},
  };
  for (const Case& c : cases) {
    const fs::path scene = broken_scene(c.name, c.from, c.to);
    const CommandResult r = run_command(exe.string() + " run " + scene.string() + " -q",
                                        scene.parent_path() / (c.name + ".log"));
    EXPECT_NE(r.status, 0) << c.name << ": " << r.output;
    EXPECT_NE(r.output.find(c.expected), std::string::npos)
        << c.name << ": expected '" << c.expected << "' in:\n"
        << r.output;
  }
}

TEST(RunScene, MaterialLibraryPrintsEveryTissueWithDerivedLatticeParameters) {
  const fs::path exe = test::tsf_executable_path();
  if (!fs::exists(exe)) GTEST_SKIP() << "not run: the tsf executable is not built at " << exe;
  const fs::path dir = test::scratch_dir("run-materials");
  const CommandResult r = run_command(
      "cd " + test::source_dir().string() + " && " + exe.string() + " run --materials --spacing 1",
      dir / "log.txt");
  ASSERT_EQ(r.status, 0) << r.output;
  for (const char* id : {"nasal_mucosa", "turbinate_soft_tissue", "cartilage", "cancellous_bone",
                         "cortical_bone", "fat", "muscle", "tumour", "vessel_wall"}) {
    // "| id | E | … | stable dt |": the row exists and its last cell is a positive number.
    const std::regex row("\\| " + std::string(id) + " \\|.*\\| ([0-9.e+-]+) \\|\n");
    std::smatch m;
    ASSERT_TRUE(std::regex_search(r.output, m, row)) << id << " in\n" << r.output;
    EXPECT_GT(std::stod(m[1].str()), 0.0) << id;
  }
}

TEST(RunSceneRobustness, MaterialLibraryErrorsNameTheKeyPath) {
  const fs::path exe = test::tsf_executable_path();
  if (!fs::exists(exe)) GTEST_SKIP() << "not run: the tsf executable is not built at " << exe;
  std::string text = read_text(test::source_dir() / "materials" / "tissues.yaml");
  const std::string from = "    youngs_modulus_pa: 3.25e3";
  const auto at = text.find(from);
  ASSERT_NE(at, std::string::npos);
  text.replace(at, from.size(), "    youngs_modulus_pa: -3");
  const fs::path dir = test::scratch_dir("run-bad-library");
  std::ofstream(dir / "bad.yaml") << text;
  const CommandResult r = run_command(
      exe.string() + " run --materials --library " + (dir / "bad.yaml").string(), dir / "log.txt");
  EXPECT_NE(r.status, 0);
  EXPECT_NE(
      r.output.find("materials.fat.youngs_modulus_pa: expected a number in [1, 1e+11], got -3"),
      std::string::npos)
      << r.output;
  // ν needs its source: a citation's first author or "assumed: why".
  text = read_text(test::source_dir() / "materials" / "tissues.yaml");
  const std::string nu_source =
      "    poisson_ratio_source: \"assumed: nearly incompressible adipose";
  const auto line = text.find(nu_source);
  ASSERT_NE(line, std::string::npos);
  text.replace(line, nu_source.size(),
               "    poisson_ratio_source: \"guessed: nearly incompressible adipose");
  std::ofstream(dir / "bad-nu.yaml") << text;
  const CommandResult nu =
      run_command(exe.string() + " run --materials --library " + (dir / "bad-nu.yaml").string(),
                  dir / "log-nu.txt");
  EXPECT_NE(nu.status, 0);
  EXPECT_NE(nu.output.find("materials.fat.poisson_ratio_source"), std::string::npos) << nu.output;
}

}  // namespace
}  // namespace tsf
