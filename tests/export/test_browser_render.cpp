// A real consumer draws what `tsf export` writes: three.js's GLTFLoader in headless Chromium
// (tools/threejs/render-gltf.js) renders the sinus model decimated to 100 k triangles and the
// cut-block scene's animation, and the pixels are checked: the model covers the picture, in
// tissue colours, the right way up; the animation's first and last frames differ.
//
// Needs Node.js (`node`), Chromium (Debian `chromium`) and three.js (tools/threejs/install.sh,
// npm ci from the lockfile; run here when missing). Each test skips saying which is absent, or,
// with TSF_REQUIRE_BROWSER_TEST=1 (as .ci/run sets it), fails saying so.
// The rendered pictures stay in the test's scratch folder; docs/export.md shows them.
#include <gtest/gtest.h>

#include <cstdlib>

#include "export_test_helpers.h"
#include "support/tsf_process.h"
#include "tsf/export/tissue_palette.h"

namespace tsf::exporter {
namespace {
using namespace test;
using ::tsf::test::ProcessRun;
using ::tsf::test::run_logged;
using ::tsf::test::run_tsf;
using ::tsf::test::shell_quoted;

std::optional<std::string> chromium_executable() {
  if (const char* env = std::getenv("TSF_CHROMIUM"); env && *env) return std::string(env);
  for (const char* name : {"chromium", "chromium-browser", "google-chrome"}) {
    const ProcessRun r = run_logged(std::string("command -v ") + name,
                                    tsf::test::scratch_dir("which") / "which.txt");
    if (r.status == 0) return name;
  }
  return std::nullopt;
}

/// CI sets TSF_REQUIRE_BROWSER_TEST=1 (.ci/run): there a missing prerequisite fails the test.
bool browser_test_required() {
  const char* env = std::getenv("TSF_REQUIRE_BROWSER_TEST");
  return env && std::string(env) == "1";
}

/// Skips, saying which is absent, unless node, Chromium and three.js are there (installing
/// three.js when npm can); fails instead where the browser test is required.
#define TSF_BROWSER_OR_SKIP(node)                                                               \
  const auto node##_opt = ::tsf::exporter::test::node_executable();                             \
  std::string node##_missing;                                                                   \
  if (!node##_opt)                                                                              \
    node##_missing =                                                                            \
        "Node.js ('node') is not installed (Debian package nodejs; scripts/setup.sh "           \
        "installs it)";                                                                         \
  else if (!chromium_executable())                                                              \
    node##_missing =                                                                            \
        "Chromium is not installed (Debian package chromium; scripts/setup.sh "                 \
        "installs it), so three.js cannot render in a browser";                                 \
  else {                                                                                        \
    const fs::path install = tsf::test::source_dir() / "tools" / "threejs" / "install.sh";      \
    const ProcessRun r =                                                                        \
        run_logged(shell_quoted(install), tsf::test::scratch_dir("three-install") / "log.txt"); \
    if (r.status == 2)                                                                          \
      node##_missing = r.output;                                                                \
    else                                                                                        \
      ASSERT_EQ(r.status, 0) << "installing three.js failed: " << r.output;                     \
  }                                                                                             \
  if (!node##_missing.empty() && browser_test_required())                                       \
    FAIL() << "TSF_REQUIRE_BROWSER_TEST=1 but " << node##_missing;                              \
  if (!node##_missing.empty()) GTEST_SKIP() << "not run: " << node##_missing;                   \
  const std::string node = *node##_opt

/// Renders `model` with tools/threejs/render-gltf.js; the report (null on failure).
nlohmann::json render(const std::string& node, const fs::path& model, const fs::path& out,
                      const std::string& extra) {
  const fs::path script = tsf::test::source_dir() / "tools" / "threejs" / "render-gltf.js";
  const ProcessRun r =
      run_logged("'" + node + "' " + shell_quoted(script) + " " + shell_quoted(model) + " --out " +
                     shell_quoted(out) + " " + extra,
                 out / (model.stem().string() + "-render.log"));
  if (r.status != 0) {
    ADD_FAILURE() << "render-gltf.js failed (" << r.status << "): " << r.output;
    return nullptr;
  }
  // The report is the last line (Chromium may print above it).
  const std::size_t start = r.output.rfind("\n{");
  try {
    return nlohmann::json::parse(r.output.substr(start == std::string::npos ? 0 : start + 1));
  } catch (const nlohmann::json::exception&) {
    ADD_FAILURE() << "render-gltf.js printed no JSON report: " << r.output;
    return nullptr;
  }
}

std::string hex(const std::array<std::uint8_t, 3>& c) {
  char b[8];
  std::snprintf(b, sizeof(b), "%02x%02x%02x", c[0], c[1], c[2]);
  return b;
}

TEST(BrowserRender, SinusModelAt100kTrianglesIsDrawnColouredAndUpright) {
  TSF_EXECUTABLE_OR_SKIP(tsf);
  TSF_BROWSER_OR_SKIP(node);
  const fs::path dir = tsf::test::scratch_dir("browser-sinus");
  const ProcessRun seg =
      run_tsf(tsf, "segment " +
                       shell_quoted(tsf::test::samples_dir() / "ct-head-cranium" / "cranium.nrrd") +
                       " --preset sinus --no-preview -q -o " + shell_quoted(dir / "cranium"));
  if (seg.status != 0 && seg.output.find("ITK") != std::string::npos)
    GTEST_SKIP() << "not run: this build segments no CT (TSF_WITH_ITK=OFF): " << seg.output;
  ASSERT_EQ(seg.status, 0) << seg.output;
  const ProcessRun exp =
      run_tsf(tsf, "export " + shell_quoted(dir / "cranium-density.nrrd") +
                       " --decimate 100000 --stats -o " + shell_quoted(dir / "sinus.glb"));
  ASSERT_EQ(exp.status, 0) << exp.output;
  const nlohmann::json stats = nlohmann::json::parse(exp.output);
  EXPECT_LE(stats["triangles"].get<std::size_t>(), 100000u);
  EXPECT_EQ(stats["written"]["zero_area"], 0);
  EXPECT_EQ(stats["written"]["duplicates"], 0);

  // Front view (from +Z, anterior in y-up axes) with +Y (superior) up.
  const nlohmann::json r = render(node, dir / "sinus.glb", dir, "--size 640x640 --name sinus");
  ASSERT_TRUE(r.is_object());
  std::cout << "[three.js] " << r.value("three", "") << " " << r["frames"][0]["stats"].dump()
            << "\n";
  const auto& s = r["frames"][0]["stats"];
  EXPECT_GT(s["covered_fraction"].get<double>(), 0.1) << "the model fills the picture";
  EXPECT_GT(s["chromatic_fraction"].get<double>(), 0.6) << "tissue colours, not grey";
  const auto mean = s["mean_rgb"].get<std::vector<double>>();
  EXPECT_GT(mean[0], mean[2] + 20.0) << "warm tissue colours: more red than blue";
  // Upright: the skull's vertex is at the top of the picture (a rounded dome, narrow), the CT's
  // lower crop at the bottom (a flat cut, wide).
  EXPECT_LT(s["top_band_width"].get<double>(), 0.8 * s["bottom_band_width"].get<double>())
      << "the model looks upside down";
  // The materials three.js made: one per tissue, named, in the tissue's colour.
  std::map<std::string, std::string> colour_of;
  for (const auto& m : r["materials"]) colour_of[m["name"]] = m["color"];
  ASSERT_TRUE(colour_of.count("soft-tissue")) << r["materials"].dump();
  EXPECT_EQ(colour_of["soft-tissue"], hex(tissue_colour_srgb(kLabelSoftTissue)));
  for (const auto& m : r["materials"]) EXPECT_FALSE(m["vertexColors"].get<bool>());
}

TEST(BrowserRender, CutBlockAnimationChangesBetweenItsFirstAndLastFrame) {
  TSF_EXECUTABLE_OR_SKIP(tsf);
  TSF_BROWSER_OR_SKIP(node);
  const fs::path dir = tsf::test::scratch_dir("browser-cut");
  const ProcessRun sim = run_tsf(
      tsf, "simulate " + shell_quoted(tsf::test::source_dir() / "scenes" / "cut-block.yaml") +
               " --backend cpu -q --out " + shell_quoted(dir / "run"));
  ASSERT_EQ(sim.status, 0) << sim.output;
  ASSERT_TRUE(fs::exists(dir / "run" / "states.tsfmesh")) << "the shipped scene saves its states";
  const ProcessRun exp = run_tsf(tsf, "export " + shell_quoted(dir / "run" / "states.tsfmesh") +
                                          " --frames all --time-scale 50 --stats -o " +
                                          shell_quoted(dir / "cut" / "cut-block.glb"));
  ASSERT_EQ(exp.status, 0) << exp.output;
  const nlohmann::json stats = nlohmann::json::parse(exp.output);
  ASSERT_TRUE(stats["animated"].get<bool>()) << exp.output;
  EXPECT_GT(stats["topology_runs"].get<int>(), 1) << "the cut and the ablation re-meshed";
  EXPECT_EQ(stats["written"]["zero_area"], 0);

  // Seen from the front-left and above, so the cut-off end is visible.
  const nlohmann::json r = render(node, dir / "cut" / "cut-block.glb", dir,
                                  "--size 640x400 --yaw 30 --pitch 25 --times first,last "
                                  "--name cut-block");
  ASSERT_TRUE(r.is_object());
  ASSERT_EQ(r["animations"].size(), 1u);
  const auto& a = r["animations"][0];
  EXPECT_GT(a["duration"].get<double>(), 5.0) << "0.14 s simulated × 50";
  const auto interpolations = a["interpolations"].get<std::vector<std::string>>();
  EXPECT_NE(std::find(interpolations.begin(), interpolations.end(), "STEP"), interpolations.end())
      << "STEP keys switch the topologies (three.js: InterpolateDiscrete)";
  ASSERT_EQ(r["frames"].size(), 2u);
  for (const auto& f : r["frames"])
    EXPECT_GT(f["stats"]["covered_fraction"].get<double>(), 0.05) << f["stats"].dump();
  std::cout << "[three.js] first/last " << r["frames"][1]["changed_fraction_from_first"] << "\n";
  EXPECT_GT(r["frames"][1]["changed_fraction_from_first"].get<double>(), 0.02)
      << "the last frame (cut, ablated, sagging) looks like the first";
}

}  // namespace
}  // namespace tsf::exporter
