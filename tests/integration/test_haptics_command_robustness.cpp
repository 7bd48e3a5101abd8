// `tsf haptics` given trajectory numbers that no run can hold: a point far outside the scene, a
// path speed so slow the playback would last for ages, a duplicated key. Each is refused before
// any output is written, naming the file and the key; never a crash or a huge allocation.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "support/test_data.h"
#include "support/tsf_process.h"

namespace tsf {
namespace {

namespace fs = std::filesystem;

struct Refusal {
  const char* name;
  const char* path;      ///< the trajectory file's `path:` mapping
  const char* expected;  ///< text the error must contain
};

TEST(HapticsCommandRobustness, RefusesTrajectoriesNoRunCanHoldNamingTheKey) {
  TSF_EXECUTABLE_OR_SKIP(exe);
  const fs::path dir = test::scratch_dir("haptics-command-robustness");
  const fs::path scene = test::source_dir() / "scenes" / "haptics-block.yaml";
  const Refusal cases[] = {
      {"far-keyframe",
       "{kind: keyframes, keyframes: [{time: 0, position: [-20, 0, 0]}, "
       "{time: 0.01, position: [1e12, 0, 0]}]}",
       "path.keyframes[1].position: expected a list of 3 numbers in [-100000, 100000], got "
       "1e+12"},
      {"far-target", "{kind: straight, from: [-20, 0, 0], to: [20, 0, 0], speed: 100}", ""},
      {"slow", "{kind: straight, from: [-20, 0, 0], to: [20, 0, 0], speed: 1e-12}",
       "path.speed, loop.rate: haptic playback: the trajectory lasts 4e+13 s"},
  };
  for (const Refusal& c : cases) {
    const fs::path traj = dir / (std::string(c.name) + ".yaml");
    const bool far_target = std::string(c.name) == "far-target";
    {
      std::ofstream f(traj);
      f << "stylus: {radius: 3}\n"
        << "target: {shape: sphere, size: 8, centre: "
        << (far_target ? "[0, 0, -3e5]" : "[0, 0, 0]") << "}\n"
        << "path: " << c.path << "\n";
    }
    const fs::path out = dir / c.name;
    const test::ProcessRun r =
        test::run_tsf(exe, "haptics -q --no-plot " + test::shell_quoted(scene) + " -t " +
                               test::shell_quoted(traj) + " --out " + test::shell_quoted(out));
    const std::string expected =
        far_target ? "target.centre: expected a list of 3 numbers in" : c.expected;
    EXPECT_EQ(r.status, 1) << c.name << ": " << r.output;
    EXPECT_NE(r.output.find(traj.string() + ": " + expected), std::string::npos)
        << c.name << ": " << r.output;
    EXPECT_FALSE(fs::exists(out / "samples.csv")) << c.name;
  }
}

}  // namespace
}  // namespace tsf
