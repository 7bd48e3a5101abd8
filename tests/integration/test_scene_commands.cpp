// One scene, one runtime: every scene key means the same thing in `tsf simulate`, `tsf run`,
// `tsf view` and `tsf haptics`, or that command refuses it naming the key. A table of keys ×
// commands: each case adds a key to a small box scene, runs one command and checks the effect
// in the command's report (`session`: measured on the built model) or the refusal's message.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "cube_mesh.h"
#include "support/test_data.h"
#include "support/tsf_process.h"

namespace tsf {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

/// A 12 × 8 × 8 mm box at 2 mm, clamped at x = 0, with a ball that presses its top.
const char* const kBase = R"(name: keys
lattice: {source: box, size: [12, 8, 8], spacing: 2}
material: {youngs_modulus: 30000, viscosity: 2, density: 0.001}
solver: {integrator: symplectic-euler, backend: cpu, dt: auto}
stability: {kinetic_damping: 0.01}
tissue: {voxels_per_node: 2}
)";
const char* const kTools = R"(tools:
  - {name: ball, shape: sphere, radius: 2}
script:
  frame_rate: 500
  duration: 0.01
  trajectories:
    - tool: ball
      keyframes:
        - {time: 0.0, position: [8, 4, 10], mode: press}
        - {time: 0.008, position: [8, 4, 7.5], mode: press}
)";

enum class Cmd { kSimulate, kRun, kView, kHaptics };

const char* name(Cmd c) {
  switch (c) {
    case Cmd::kSimulate:
      return "simulate";
    case Cmd::kRun:
      return "run";
    case Cmd::kView:
      return "view";
    case Cmd::kHaptics:
      return "haptics";
  }
  return "?";
}

struct Outcome {
  test::ProcessRun process;
  json session;  ///< the command's report's `session` (first instance)
  json report;
  fs::path out;
};

std::string scene_text(const std::string& extra, bool with_tools) {
  return std::string(kBase) + extra + (with_tools ? kTools : "");
}

/// Runs `command` on `scene` (YAML text) into a fresh folder; reads its report.
Outcome run_scene(Cmd command, const std::string& scene_yaml, const std::string& tag) {
  const fs::path exe = test::tsf_executable_path();
  const fs::path dir = test::scratch_dir(std::string(name(command)) + "-" + tag);
  const fs::path scene = dir / "scene.yaml";
  std::ofstream(scene) << scene_yaml;
  const bool has_outputs = scene_yaml.find("outputs:") != std::string::npos;
  Outcome o;
  o.out = dir / "out";
  const std::string q = test::shell_quoted(scene) + " --out " + test::shell_quoted(o.out);
  fs::path report;
  switch (command) {
    case Cmd::kSimulate:
      // A scene with outputs writes its report in the folder; else --report names it.
      if (has_outputs) {
        o.process = test::run_tsf(exe, "simulate -q " + q);
        report = o.out / "report.json";
      } else {
        o.process = test::run_tsf(
            exe, "simulate -q " + q + " --report " + test::shell_quoted(dir / "report.json"));
        report = dir / "report.json";
      }
      break;
    case Cmd::kRun:
      o.process = test::run_tsf(
          exe, "run -q " + test::shell_quoted(scene) + " -o " + test::shell_quoted(o.out));
      report = o.out / (has_outputs ? "report.json" : "interaction.json");
      break;
    case Cmd::kView:
      o.process = test::run_tsf(
          exe, "view -q --offscreen --frames 3 --width 160 --height 120 " + q + " --ct none");
      report = o.out / "view-report.json";
      break;
    case Cmd::kHaptics:
      o.process =
          test::run_tsf(exe, "haptics -q --no-plot " + q + " -t " +
                                 test::shell_quoted(test::source_dir() / "scenes" / "trajectories" /
                                                    "haptics-press-hold.yaml") +
                                 " --model lattice");
      report = o.out / "metrics.json";
      break;
  }
  if (o.process.status == 0 && fs::exists(report)) {
    o.report = json::parse(test::read_text(report));
    if (o.report.contains("instances") && o.report["instances"].is_array())
      o.session = o.report["instances"][0]["session"];
    else
      o.session = o.report.value("session", json(nullptr));
  }
  return o;
}

Outcome run(Cmd command, const std::string& extra, bool with_tools, const std::string& tag) {
  return run_scene(command, scene_text(extra, with_tools), tag);
}

/// `tsf view` needs VTK in the build; the test says when it is not.
bool view_built() {
  const test::ProcessRun p = test::run_tsf(test::tsf_executable_path(), "view --help");
  return p.status == 0 && p.output.find("--offscreen") != std::string::npos;
}

std::vector<Cmd> commands() {
  std::vector<Cmd> c = {Cmd::kSimulate, Cmd::kRun, Cmd::kHaptics};
  if (view_built()) c.push_back(Cmd::kView);
  return c;
}

#define TSF_NEED_EXE()                          \
  if (!fs::exists(test::tsf_executable_path())) \
  GTEST_SKIP() << "not run: the tsf executable is not built at " << test::tsf_executable_path()

// haptics plays --trajectory, not tools: its scenes have none.
bool tools_for(Cmd c) {
  return c != Cmd::kHaptics;
}

TEST(SceneKeysByCommand, LoadsReachTheModelInEveryCommand) {
  TSF_NEED_EXE();
  if (!view_built()) std::printf("tsf view is not part of this build: its column is not run\n");
  for (Cmd c : commands()) {
    const Outcome o =
        run(c, "loads:\n  - {box: {min: [9, -1, -1], max: [13, 9, 9]}, force: [0, 0, -50]}\n",
            tools_for(c), "loads");
    ASSERT_EQ(o.process.status, 0) << name(c) << ": " << o.process.output;
    ASSERT_TRUE(o.session.is_object()) << name(c) << ": " << o.report.dump().substr(0, 400);
    EXPECT_GT(o.session["loaded_nodes"].get<int>(), 0) << name(c);
  }
}

TEST(SceneKeysByCommand, TheInitialStateIsAppliedInEveryCommand) {
  TSF_NEED_EXE();
  for (Cmd c : commands()) {
    const Outcome plain = run(c, "", tools_for(c), "initial-off");
    const Outcome scaled =
        run(c, "initial: {scale: [1.05, 1, 1], about: [0, 4, 4]}\n", tools_for(c), "initial-on");
    ASSERT_EQ(plain.process.status, 0) << name(c) << ": " << plain.process.output;
    ASSERT_EQ(scaled.process.status, 0) << name(c) << ": " << scaled.process.output;
    // The stretched start stores elastic energy; the rest state none.
    EXPECT_NEAR(plain.session["elastic_nj_at_start"].get<double>(), 0.0, 1e-9) << name(c);
    EXPECT_GT(scaled.session["elastic_nj_at_start"].get<double>(), 1e-6) << name(c);
  }
}

TEST(SceneKeysByCommand, AnchorsTimeStepGravityAndEffectsMeanTheSameEverywhere) {
  TSF_NEED_EXE();
  const std::string extra =
      "anchors:\n  - box: {min: [-1, -1, -1], max: [1, 9, 9]}\n"
      "gravity: [0, 0, -9810]\n"
      "effects:\n  plasticity: {yield_strain: 0.05, creep_rate: 100}\n";
  std::vector<json> sessions;
  for (Cmd c : commands()) {
    const Outcome r = run(c, extra, tools_for(c), "keys");
    ASSERT_EQ(r.process.status, 0) << name(c) << ": " << r.process.output;
    EXPECT_GT(r.session["fixed_nodes"].get<int>(), 0) << name(c);
    EXPECT_EQ(r.session["gravity_mm_s2"], json::array({0.0, 0.0, -9810.0})) << name(c);
    EXPECT_EQ(r.session["effects_active"], json::array({"plasticity"})) << name(c);
    sessions.push_back(r.session);
  }
  // The same scene builds the same model whichever command runs it.
  for (const json& s : sessions) {
    EXPECT_EQ(s["alive_nodes"], sessions[0]["alive_nodes"]);
    EXPECT_EQ(s["fixed_nodes"], sessions[0]["fixed_nodes"]);
    EXPECT_DOUBLE_EQ(s["dt_s"].get<double>(), sessions[0]["dt_s"].get<double>());
  }
}

TEST(SceneKeysByCommand, RemovalRatesExposureAndPaintMeanTheSameEverywhere) {
  TSF_NEED_EXE();
  for (Cmd c : commands()) {
    std::string scene = scene_text("", tools_for(c));
    const std::string lattice = "lattice: {source: box, size: [12, 8, 8], spacing: 2}\n";
    scene.replace(scene.find(lattice), lattice.size(),
                  "lattice:\n  source: box\n  size: [12, 8, 8]\n  spacing: 2\n  paint:\n"
                  "    - {label: vessel, capsule: {from: [6, -1, 4], to: [6, 9, 4], radius: 1}}\n"
                  "    - {label: cortical-bone, box: {min: [-1, -1, -1], max: [13, 9, 1]}}\n");
    const std::string tissue = "tissue: {voxels_per_node: 2}\n";
    scene.replace(scene.find(tissue), tissue.size(),
                  "tissue:\n  voxels_per_node: 2\n  removal:\n    rates: {cortical-bone: {ablate: "
                  "0.05, cut: 0}}\n    feather_force_mn: 20\n  exposure: {distance_mm: 2}\n");
    const Outcome o = run_scene(c, scene, "removal");
    ASSERT_EQ(o.process.status, 0) << name(c) << ": " << o.process.output;
    const json& removal = o.session["removal"];
    EXPECT_EQ(removal["ablation_rates"]["cortical-bone"].get<double>(), 0.05) << name(c);
    EXPECT_EQ(removal["cut_rates"]["cortical-bone"].get<double>(), 0.0) << name(c);
    EXPECT_EQ(removal["rates_source"], "scene") << name(c);
    EXPECT_DOUBLE_EQ(removal["feather_force_mn"].get<double>(), 20.0) << name(c);
    EXPECT_DOUBLE_EQ(removal["exposure_distance_mm"].get<double>(), 2.0) << name(c);
    EXPECT_GT(o.session["tissue_labels_voxels"].value("vessel", 0), 0) << name(c);
    EXPECT_GT(o.session["tissue_labels_voxels"].value("cortical-bone", 0), 0) << name(c);
  }
}

TEST(SceneKeysByCommand, AnExplicitTimeStepIsTheModelsInEveryCommand) {
  TSF_NEED_EXE();
  for (Cmd c : commands()) {
    std::string scene = scene_text("", tools_for(c));
    const std::string from = "dt: auto}";
    scene.replace(scene.find(from), from.size(), "dt: 2.0e-5}");
    const Outcome o = run_scene(c, scene, "dt");
    ASSERT_EQ(o.process.status, 0) << name(c) << ": " << o.process.output;
    EXPECT_DOUBLE_EQ(o.session["dt_s"].get<double>(), 2.0e-5) << name(c);
  }
}

TEST(SceneKeysByCommand, KeysACommandCannotHonourAreRefusedByName) {
  TSF_NEED_EXE();
  struct Case {
    Cmd command;
    std::string extra;
    bool tools;
    std::string expect;
  };
  const std::string two = R"(tissues:
  - {name: a, lattice: {source: box, size: [6, 6, 6], spacing: 2}, material: {youngs_modulus: 3e4, viscosity: 2, density: 0.001}}
  - {name: b, lattice: {source: box, size: [6, 6, 6], spacing: 2, origin: [8, 0, 0]}, material: {youngs_modulus: 3e4, viscosity: 2, density: 0.001}}
)";
  std::vector<Case> cases = {
      {Cmd::kHaptics, "", true, "tools: tsf haptics"},
      {Cmd::kHaptics, "outputs: {mesh: final.ply}\n", false, "outputs: tsf haptics"},
      {Cmd::kSimulate, "pipeline: {source: {ct: nowhere.nrrd}}\n", false, "pipeline: tsf simulate"},
      {Cmd::kHaptics, "pipeline: {source: {ct: nowhere.nrrd}}\n", false, "pipeline: tsf haptics"},
  };
  if (view_built()) {
    cases.push_back(
        {Cmd::kView, "pipeline: {source: {ct: nowhere.nrrd}}\n", true, "pipeline: tsf view"});
  }
  for (const Case& c : cases) {
    const Outcome o = run(c.command, c.extra, c.tools, "refuse");
    EXPECT_NE(o.process.status, 0) << name(c.command) << " " << c.extra;
    EXPECT_NE(o.process.output.find(c.expect), std::string::npos)
        << "expected '" << c.expect << "' in: " << o.process.output;
  }
  // Several instances: simulate and run honour them (a report each); view and haptics refuse
  // `tissues` (they run one instance).
  const fs::path dir = test::scratch_dir("two-instances");
  std::string scene = std::string(kBase);
  scene = scene.substr(0, scene.find("lattice:")) +
          "solver: {integrator: symplectic-euler, backend: cpu, dt: auto}\n" + two;
  std::ofstream(dir / "two.yaml") << scene << kTools;
  const test::ProcessRun sim = test::run_tsf(
      test::tsf_executable_path(), "simulate -q " + test::shell_quoted(dir / "two.yaml") +
                                       " --report " + test::shell_quoted(dir / "two.json"));
  ASSERT_EQ(sim.status, 0) << sim.output;
  EXPECT_EQ(json::parse(test::read_text(dir / "two.json"))["instances"].size(), 2u);
  std::ofstream(dir / "two-bare.yaml") << scene;
  for (Cmd c : commands()) {
    if (c != Cmd::kView && c != Cmd::kHaptics) continue;
    const std::string args =
        c == Cmd::kView ? "view -q --offscreen --frames 1 "
                        : "haptics -q --no-plot -t " +
                              test::shell_quoted(test::source_dir() / "scenes" / "trajectories" /
                                                 "haptics-press-hold.yaml") +
                              " ";
    const test::ProcessRun p = test::run_tsf(
        test::tsf_executable_path(),
        args + test::shell_quoted(dir / (c == Cmd::kView ? "two.yaml" : "two-bare.yaml")) +
            " --out " + test::shell_quoted(dir / (std::string("out-") + name(c))));
    EXPECT_NE(p.status, 0) << name(c);
    EXPECT_NE(p.output.find(std::string("tissues: tsf ") + name(c)), std::string::npos) << p.output;
  }
  // A lattice-only scene's run length is `tsf simulate`'s: the others refuse it by name.
  std::string lattice_only = std::string(kBase);
  lattice_only = lattice_only.substr(0, lattice_only.find("tissue:"));
  const std::string from = "dt: auto}";
  lattice_only.replace(lattice_only.find(from), from.size(), "dt: auto, steps: 10}");
  const Outcome simulated = run_scene(Cmd::kSimulate, lattice_only, "steps");
  EXPECT_EQ(simulated.process.status, 0) << simulated.process.output;
  EXPECT_EQ(simulated.report["steps_run"].get<int>(), 10);
  std::vector<std::pair<Cmd, std::string>> refusals = {
      {Cmd::kRun, "tsf run needs an interaction scene"},
      {Cmd::kHaptics, "solver.steps: tsf haptics"}};
  if (view_built()) refusals.push_back({Cmd::kView, "solver.steps: tsf view"});
  for (const auto& [c, expect] : refusals) {
    const Outcome o = run_scene(c, lattice_only, "steps");
    EXPECT_NE(o.process.status, 0) << name(c);
    EXPECT_NE(o.process.output.find(expect), std::string::npos)
        << "expected '" << expect << "' in: " << o.process.output;
  }
}

TEST(SceneKeysByCommand, AMeshToolPressesInEveryCommandThatPlaysTools) {
  TSF_NEED_EXE();
  // The ball of kTools as a closed mesh file (a 4 mm cube in its own frame, OBJ).
  const fs::path dir = test::scratch_dir("mesh-tool-file");
  std::ofstream(dir / "cube.obj") << test::cube_obj();
  std::string tools = kTools;
  const std::string sphere = "{name: ball, shape: sphere, radius: 2}";
  tools.replace(tools.find(sphere), sphere.size(),
                "{name: ball, shape: mesh, file: " + (dir / "cube.obj").string() + "}");
  for (Cmd c : commands()) {
    if (c == Cmd::kHaptics) continue;  // it drives --trajectory's stylus, not scene tools
    const Outcome o = run_scene(c, std::string(kBase) + tools, "mesh-tool");
    ASSERT_EQ(o.process.status, 0) << name(c) << ": " << o.process.output;
    if (c == Cmd::kView) {
      EXPECT_GT(o.report["max_force_un"].get<double>(), 0.0) << "the pressed box pushes back";
      continue;
    }
    int held = 0;
    for (const json& sample : o.report["contact"]) held += sample["nodes_held"].get<int>() > 0;
    EXPECT_GT(held, 0) << name(c) << ": the mesh tool held nodes";
  }
}

TEST(SceneKeysByCommand, InstanceContactIsHonouredWhereSeveralInstancesRun) {
  TSF_NEED_EXE();
  const std::string scene = std::string(R"(name: keys
solver: {integrator: symplectic-euler, backend: cpu, dt: auto}
gravity: [0, 0, -9810]
tissues:
  - {name: a, lattice: {source: box, size: [6, 6, 6], spacing: 2, origin: [0, 0, 8]}, material: {youngs_modulus: 3e4, viscosity: 2, density: 0.001}, contact: {pushed_by: [b]}}
  - {name: b, lattice: {source: box, size: [12, 12, 6], spacing: 2, origin: [-3, -3, 0]}, material: {youngs_modulus: 3e5, viscosity: 2, density: 0.001}, anchors: [{box: {min: [-9, -9, -9], max: [20, 20, 20]}}]}
)") + kTools;
  for (Cmd c : {Cmd::kSimulate, Cmd::kRun}) {
    const Outcome o = run_scene(c, scene, "contact");
    ASSERT_EQ(o.process.status, 0) << name(c) << ": " << o.process.output;
    const json& a = o.report["instances"][0];
    ASSERT_TRUE(a["body_contact"].is_object()) << name(c) << ": " << a.dump().substr(0, 300);
    EXPECT_EQ(a["body_contact"]["pushed_by"], json::array({"b"})) << name(c);
    EXPECT_FALSE(a["body_contact"]["samples"].empty()) << name(c);
    EXPECT_FALSE(o.report["instances"][1].contains("body_contact")) << "b is pushed by nothing";
  }
}

TEST(SceneKeysByCommand, EveryOutputLandsInTheOutputFolderAndAFullFolderIsRefused) {
  TSF_NEED_EXE();
  const std::string outputs =
      "outputs: {mesh: final.ply, rest_mesh: rest.ply, report: report.json, states: "
      "states.tsfmesh, states_every: 2}\n";
  std::vector<Cmd> writers = {Cmd::kSimulate, Cmd::kRun};
  if (view_built()) writers.push_back(Cmd::kView);
  for (Cmd c : writers) {
    const Outcome o = run(c, outputs, true, "outputs");
    ASSERT_EQ(o.process.status, 0) << name(c) << ": " << o.process.output;
    for (const char* f : {"final.ply", "rest.ply", "report.json", "states.tsfmesh"})
      EXPECT_TRUE(fs::exists(o.out / f)) << name(c) << ": " << (o.out / f);
    // The same folder again: refused (it holds a run), then --force replaces it.
    const fs::path scene = o.out.parent_path() / "scene.yaml";
    const std::string args = std::string(name(c)) + " -q " + test::shell_quoted(scene) +
                             (c == Cmd::kRun ? " -o " : " --out ") + test::shell_quoted(o.out) +
                             (c == Cmd::kView ? " --offscreen --frames 2 --ct none" : "");
    const test::ProcessRun again = test::run_tsf(test::tsf_executable_path(), args);
    EXPECT_NE(again.status, 0) << name(c);
    EXPECT_NE(again.output.find("is not empty"), std::string::npos) << again.output;
    const test::ProcessRun forced = test::run_tsf(test::tsf_executable_path(), args + " --force");
    EXPECT_EQ(forced.status, 0) << name(c) << ": " << forced.output;
  }
  // A folder of someone else's files is never emptied, even with --force.
  const fs::path mine = test::scratch_dir("not-a-run");
  std::ofstream(mine / "notes.txt") << "mine\n";
  const Outcome o = run(Cmd::kSimulate, outputs, true, "outputs-foreign");
  const test::ProcessRun p = test::run_tsf(
      test::tsf_executable_path(), "simulate -q --force " +
                                       test::shell_quoted(o.out.parent_path() / "scene.yaml") +
                                       " --out " + test::shell_quoted(mine));
  EXPECT_NE(p.status, 0);
  EXPECT_NE(p.output.find("no tsf run wrote"), std::string::npos) << p.output;
  EXPECT_TRUE(fs::exists(mine / "notes.txt"));
}

}  // namespace
}  // namespace tsf

namespace tsf {
namespace {

TEST(SceneRunInterrupt, CtrlCStopsAtAFrameAndWritesTheReportMarkedInterrupted) {
  const fs::path exe = test::tsf_executable_path();
  if (!fs::exists(exe)) GTEST_SKIP() << "not run: the tsf executable is not built at " << exe;
  const fs::path dir = test::scratch_dir("interrupt");
  const fs::path out = dir / "out";
  // A script far longer than the signal's delay: SIGINT arrives mid-script.
  const test::ProcessRun p =
      test::run_logged("timeout -s INT 6 " + exe.string() + " simulate -q " +
                           (test::source_dir() / "scenes" / "cut-block.yaml").string() +
                           " --backend cpu --duration 600 --out " + out.string(),
                       dir / "log.txt");
  EXPECT_NE(p.status, 0) << p.output;
  EXPECT_NE(p.output.find("interrupted"), std::string::npos) << p.output;
  ASSERT_TRUE(fs::exists(out / "report.json")) << p.output;
  const json r = json::parse(test::read_text(out / "report.json"));
  EXPECT_TRUE(r["interrupted"].get<bool>());
  EXPECT_LT(r["frames"].get<int>(), r["frames_planned"].get<int>());
  EXPECT_TRUE(fs::exists(out / "final.ply"));
  // Nothing half-written: no temporary file is left in the folder.
  for (const fs::directory_entry& e : fs::directory_iterator(out))
    EXPECT_EQ(e.path().filename().string().find(".tmp"), std::string::npos) << e.path();
}

}  // namespace
}  // namespace tsf
