// Stability that tells the truth, end to end (docs/stability.md): a scene whose solver.dt is
// above the stable estimate is refused naming the estimate and the key that allows it; allowed,
// it runs, its report's first line and `stability.verdict` say unstable and the command exits
// non-zero, unless stability.allow_unstable keeps the exit status 0; dt: auto says how the
// estimate was made and ends with a verdict that is not unstable.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>

#include "support/test_data.h"
#include "support/tsf_process.h"

namespace tsf {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

#define TSF_NEED_EXE()                          \
  if (!fs::exists(test::tsf_executable_path())) \
  GTEST_SKIP() << "not run: the tsf executable is not built at " << test::tsf_executable_path()

/// A lattice-only scene (`tsf simulate`) and the same box with a pressing ball (`tsf run`).
std::string lattice_scene(const std::string& dt, const std::string& stability) {
  return "name: over-step\n"
         "lattice: {source: box, size: [12, 8, 8], spacing: 2}\n"
         "material: {youngs_modulus: 30000, viscosity: 2, density: 0.001}\n"
         "solver: {integrator: symplectic-euler, backend: cpu, dt: " +
         dt +
         ", steps: 2000, report_every: 50}\n"
         "gravity: [0, 0, -9810]\n"
         "anchors: [{plane: {point: [1, 0, 0], normal: [1, 0, 0]}}]\n"
         "initial: {scale: [1.0, 1.0, 0.8], about: [0, 0, 0]}\n"
         "stability: {kinetic_damping: 0.01" +
         stability + "}\n";
}

std::string run_scene(const std::string& dt, const std::string& stability) {
  return "name: over-step-run\n"
         "lattice: {source: box, size: [12, 8, 8], spacing: 2}\n"
         "material: {youngs_modulus: 30000, viscosity: 2, density: 0.001}\n"
         "solver: {integrator: symplectic-euler, backend: cpu, dt: " +
         dt +
         "}\n"
         "gravity: [0, 0, -9810]\n"
         "stability: {kinetic_damping: 0.01" +
         stability +
         "}\n"
         "tissue: {voxels_per_node: 2}\n"
         "anchors: [{plane: {point: [1, 0, 0], normal: [1, 0, 0]}}]\n"
         "tools: [{name: ball, shape: sphere, radius: 2}]\n"
         "script:\n"
         "  frame_rate: 500\n"
         "  duration: 0.04\n"
         "  trajectories:\n"
         "    - tool: ball\n"
         "      keyframes:\n"
         "        - {time: 0.0, position: [8, 4, 10], mode: press}\n"
         "        - {time: 0.008, position: [8, 4, 7.5], mode: press}\n"
         "        - {time: 0.010, position: [8, 4, 12], mode: idle}\n";
}

struct Outcome {
  test::ProcessRun process;
  json report;
};

/// Writes `yaml` into a fresh folder and runs `tsf simulate` on it (report.json beside it) or
/// `tsf run` (out/run-report.json, with run-report.md's text as `markdown`).
Outcome run_command(bool simulate, const std::string& yaml, const std::string& tag) {
  const fs::path dir =
      test::scratch_dir(std::string("stability-") + (simulate ? "simulate-" : "run-") + tag);
  const std::string scene = test::shell_quoted(dir / "scene.yaml");
  std::ofstream(dir / "scene.yaml") << yaml;
  const fs::path report = simulate ? dir / "report.json" : dir / "out" / "run-report.json";
  Outcome o;
  o.process =
      test::run_tsf(test::tsf_executable_path(),
                    simulate ? "simulate " + scene + " --report " + test::shell_quoted(report)
                             : "run -q " + scene + " -o " + test::shell_quoted(dir / "out"));
  if (fs::exists(report)) o.report = json::parse(test::read_text(report));
  if (fs::exists(dir / "out" / "run-report.md"))
    o.report["markdown"] = test::read_text(dir / "out" / "run-report.md");
  return o;
}

Outcome simulate(const std::string& yaml, const std::string& tag) {
  return run_command(true, yaml, tag);
}

Outcome run(const std::string& yaml, const std::string& tag) {
  return run_command(false, yaml, tag);
}

/// The stable estimate of the scene, from a dt: auto run's report.
double stable_estimate(const Outcome& automatic) {
  return automatic.report.at("time_step").at("stable_estimate_s").get<double>();
}

std::string times(double dt) {
  char text[64];
  std::snprintf(text, sizeof text, "%.6g", dt);
  return text;
}

TEST(StabilityCommands, SimulateAutoSaysHowAndIsNotUnstable) {
  TSF_NEED_EXE();
  const Outcome o = simulate(lattice_scene("auto", ""), "auto");
  ASSERT_EQ(o.process.status, 0) << o.process.output;
  EXPECT_EQ(o.process.output.rfind(o.report["stability"].value("verdict", "?") + ":", 0), 0u)
      << "the summary's first line is the verdict:\n"
      << o.process.output;
  EXPECT_NE(o.report["stability"]["verdict"], "unstable") << o.report["stability"].dump(2);
  EXPECT_NE(o.report["time_step"].value("how", "").find("dt: auto = 0.9 ×"), std::string::npos)
      << o.report["time_step"].dump(2);
}

TEST(StabilityCommands, SimulateRefusesAStepAboveTheEstimate) {
  TSF_NEED_EXE();
  const double stable = stable_estimate(simulate(lattice_scene("auto", ""), "estimate"));
  const Outcome o = simulate(lattice_scene(times(5.6 * stable), ""), "refused");
  EXPECT_NE(o.process.status, 0);
  EXPECT_NE(o.process.output.find("solver.dt"), std::string::npos) << o.process.output;
  EXPECT_NE(o.process.output.find("stable estimate " + times(stable).substr(0, 4)),
            std::string::npos)
      << o.process.output;
  EXPECT_NE(o.process.output.find("stability.allow_unsafe_dt: true"), std::string::npos)
      << o.process.output;
  EXPECT_TRUE(o.report.is_null()) << "a refused scene runs nothing";
}

TEST(StabilityCommands, SimulateAllowedOverStepIsReportedUnstableAndFails) {
  TSF_NEED_EXE();
  const double stable = stable_estimate(simulate(lattice_scene("auto", ""), "estimate2"));
  const Outcome o =
      simulate(lattice_scene(times(5.6 * stable), ", allow_unsafe_dt: true"), "allowed");
  EXPECT_NE(o.process.status, 0) << o.process.output;
  EXPECT_EQ(o.process.output.rfind("unstable:", 0), 0u) << o.process.output;
  ASSERT_TRUE(o.report.is_object()) << o.process.output;
  EXPECT_EQ(o.report["stability"]["verdict"], "unstable") << o.report["stability"].dump(2);
  EXPECT_NEAR(o.report["time_step"]["dt_over_estimate"].get<double>(), 5.6, 0.01);

  // Opted out: still reported unstable, exit status 0.
  const Outcome kept =
      simulate(lattice_scene(times(5.6 * stable), ", allow_unsafe_dt: true, allow_unstable: true"),
               "allowed-kept");
  EXPECT_EQ(kept.process.status, 0) << kept.process.output;
  EXPECT_EQ(kept.report["stability"]["verdict"], "unstable");
  EXPECT_EQ(kept.report["stability"]["allowed_by_scene"], true);
}

TEST(StabilityCommands, SceneKeysAreReadStrictly) {
  TSF_NEED_EXE();
  const Outcome o = simulate(lattice_scene("auto", ", allow_unsafe_dt: perhaps"), "strict");
  EXPECT_NE(o.process.status, 0);
  EXPECT_NE(o.process.output.find("allow_unsafe_dt"), std::string::npos) << o.process.output;
  EXPECT_NE(o.process.output.find("expected true or false"), std::string::npos) << o.process.output;
}

TEST(StabilityCommands, RunRefusesThenReportsTheAllowedOverStepUnstable) {
  TSF_NEED_EXE();
  const Outcome automatic = run(run_scene("auto", ""), "auto");
  ASSERT_EQ(automatic.process.status, 0) << automatic.process.output;
  const json& s = automatic.report["stability"];
  EXPECT_NE(s.value("verdict", "unstable"), "unstable") << s.dump(2);
  EXPECT_NE(automatic.report.value("markdown", "").find("**Stability: "), std::string::npos);
  const double stable =
      automatic.report["interaction"]["session"]["time_step"]["stable_estimate_s"];

  const Outcome refused = run(run_scene(times(5.6 * stable), ""), "refused");
  EXPECT_NE(refused.process.status, 0);
  EXPECT_NE(refused.process.output.find("stability.allow_unsafe_dt: true"), std::string::npos)
      << refused.process.output;

  const Outcome allowed = run(run_scene(times(5.6 * stable), ", allow_unsafe_dt: true"), "allowed");
  EXPECT_NE(allowed.process.status, 0) << allowed.process.output;
  EXPECT_EQ(allowed.report.value("verdict", ""), "unstable") << allowed.process.output;
  EXPECT_EQ(allowed.report["stability"].value("verdict", ""), "unstable");
  EXPECT_EQ(allowed.report.value("markdown", "").rfind("# over-step-run: unstable", 0), 0u)
      << allowed.report.value("markdown", "").substr(0, 400);

  const Outcome kept =
      run(run_scene(times(5.6 * stable), ", allow_unsafe_dt: true, allow_unstable: true"), "kept");
  EXPECT_EQ(kept.process.status, 0) << kept.process.output;
  EXPECT_EQ(kept.report.value("verdict", ""), "unstable");
  EXPECT_NE(
      kept.report.value("markdown", "").find("`stability.allow_unstable: true` kept the exit"),
      std::string::npos);
}

}  // namespace
}  // namespace tsf
