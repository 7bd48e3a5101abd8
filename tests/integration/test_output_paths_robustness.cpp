// Where commands write, facing a scene that tries to write elsewhere: a scene may choose its run's
// output folder only inside the working folder (pipeline.outputs.folder), and everything a run
// writes stays inside its output folder; the refusal names the scene and the key, and nothing
// is created. (Outputs of instances, `outputs:`, are checked by the scene tests.)
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <regex>
#include <string>

#include "support/test_data.h"
#include "support/tsf_process.h"

namespace tsf {
namespace {
namespace fs = std::filesystem;

/// scenes/sinus-ci.yaml copied to `dir` with its CT made absolute and `folder` as its
/// pipeline.outputs.folder.
fs::path scene_writing_to(const fs::path& dir, const std::string& folder) {
  std::ifstream in(test::source_dir() / "scenes" / "sinus-ci.yaml");
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  text = std::regex_replace(text, std::regex("ct: \\.\\./data-samples"),
                            "ct: " + (test::source_dir() / "data-samples").string());
  text = std::regex_replace(text, std::regex("  outputs:\n"),
                            "  outputs:\n    folder: " + folder + "\n");
  const fs::path scene = dir / "escape.yaml";
  std::ofstream(scene) << text;
  return scene;
}

TEST(OutputPathsRobustness, ASceneCannotChooseAnOutputFolderOutsideTheWorkingFolder) {
  TSF_EXECUTABLE_OR_SKIP(tsf);
  const fs::path dir = test::scratch_dir("output-escape");
  const fs::path outside = fs::temp_directory_path() / "tsf-output-escape-target";
  fs::remove_all(outside);
  for (const std::string& folder : {outside.string(), std::string("../../../../../../../tmp/x")}) {
    const fs::path scene = scene_writing_to(dir, folder);
    const test::ProcessRun r = test::run_tsf(tsf, "run -q " + test::shell_quoted(scene));
    EXPECT_NE(r.status, 0) << r.output;
    EXPECT_NE(r.output.find("escape.yaml: pipeline.outputs.folder: '"), std::string::npos)
        << r.output;
    EXPECT_NE(r.output.find("is not a folder inside the working folder"), std::string::npos)
        << r.output;
    EXPECT_NE(r.output.find("give -o DIR to write elsewhere"), std::string::npos) << r.output;
  }
  EXPECT_FALSE(fs::exists(outside)) << "the refused folder was created";
}

}  // namespace
}  // namespace tsf
