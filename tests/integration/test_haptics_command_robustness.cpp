// `tsf haptics` given files no run can hold: a point far outside the scene, a path speed so slow
// the playback would last for ages, a key written twice (in the trajectory or the scene), a list
// as a key, aliases that nest without end or multiply a small file. Each is
// refused before any output is written, naming the file and the key; never a crash or a huge
// allocation.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "support/test_data.h"
#include "support/tsf_process.h"

namespace tsf {
namespace {

namespace fs = std::filesystem;

const char* const kTarget =
    "stylus: {radius: 3}\ntarget: {shape: sphere, size: 8, centre: [0, 0, 0]}\n";
const char* const kPass = "path: {kind: straight, from: [-20, 0, 0], to: [20, 0, 0], speed: 100}\n";

std::string repeated(const std::string& s, int n) {
  std::string out;
  for (int i = 0; i < n; ++i) out += s;
  return out;
}

/// Nine levels of aliases, each ten times the one before: 10^9 values from 400 bytes.
std::string laughs() {
  std::string s = "a0: &a0 [x, x, x, x, x, x, x, x, x, x]\n";
  for (int i = 1; i < 9; ++i) {
    s += "a" + std::to_string(i) + ": &a" + std::to_string(i) + " [";
    for (int k = 0; k < 10; ++k) s += (k ? ", *a" : "*a") + std::to_string(i - 1);
    s += "]\n";
  }
  return s;
}

struct Refusal {
  const char* name;
  std::string trajectory;  ///< the trajectory file
  std::string scene_tail;  ///< appended to a copy of scenes/haptics-block.yaml
  std::string expected;    ///< the error, after "<file>: "
};

TEST(HapticsCommandRobustness, RefusesFilesNoRunCanHoldNamingTheKey) {
  TSF_EXECUTABLE_OR_SKIP(exe);
  const fs::path dir = test::scratch_dir("haptics-command-robustness");
  const std::string block = test::read_text(test::source_dir() / "scenes" / "haptics-block.yaml");
  ASSERT_FALSE(block.empty());
  const Refusal cases[] = {
      {"far-keyframe",
       std::string(kTarget) +
           "path: {kind: keyframes, keyframes: [{time: 0, position: [-20, 0, 0]},\n"
           "  {time: 0.01, position: [1e12, 0, 0]}]}\n",
       "",
       "path.keyframes[1].position: expected a list of 3 numbers in [-100000, 100000], got "
       "1e+12"},
      {"far-target",
       std::string("target: {shape: sphere, size: 8, centre: [0, 0, -3e5]}\n") + kPass, "",
       "target.centre: expected a list of 3 numbers in [-100000, 100000], got -300000"},
      {"slow",
       std::string(kTarget) +
           "path: {kind: straight, from: [-20, 0, 0], to: [20, 0, 0], speed: 1e-12}\n",
       "", "path.speed, loop.rate: haptic playback: the trajectory lasts 4e+13 s"},
      {"twice-top", std::string(kTarget) + kPass + "stylus: {radius: 5}\n", "",
       "stylus: the key is given twice, first at line 1: expected each key once (line 4)"},
      {"twice-nested",
       std::string(kTarget) +
           "path: {kind: straight, from: [-20, 0, 0], to: [20, 0, 0], speed: 1, speed: 100}\n",
       "", "path.speed: the key is given twice, first at line 3"},
      {"twice-scene", std::string(kTarget) + kPass, "name: another-name\n",
       "name: the key is given twice, first at line 6"},
      {"list-as-key", std::string(kTarget) + kPass + "? [1, 2]\n: 3\n", "",
       "(top level): expected a plain key, not a list or mapping (line 4)"},
      {"recursive-alias", std::string(kTarget) + kPass + "loop: &x [1, *x]\n", "",
       "loop" + repeated("[1]", 25) + "[...: nested more than 256 levels deep (line 4)"},
      {"alias-bomb", std::string(kTarget) + kPass + laughs(), "",
       "a5[7][8][8][8][7][0]: the file holds more than 10^6 values (aliases?) (line 4)"},
  };
  for (const Refusal& c : cases) {
    const fs::path traj = dir / (std::string(c.name) + ".yaml");
    const fs::path scene = dir / (std::string(c.name) + "-scene.yaml");
    std::ofstream(traj) << c.trajectory;
    std::ofstream(scene) << block << c.scene_tail;
    const fs::path out = dir / c.name;
    const test::ProcessRun r =
        test::run_tsf(exe, "haptics -q --no-plot " + test::shell_quoted(scene) + " -t " +
                               test::shell_quoted(traj) + " --out " + test::shell_quoted(out));
    const fs::path named = c.scene_tail.empty() ? traj : scene;
    EXPECT_EQ(r.status, 1) << c.name << ": " << r.output;
    EXPECT_NE(r.output.find(named.string() + ": " + c.expected), std::string::npos)
        << c.name << ": " << r.output;
    EXPECT_FALSE(fs::exists(out / "samples.csv")) << c.name;
  }
}

}  // namespace
}  // namespace tsf
