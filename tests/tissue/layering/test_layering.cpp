// tissue/'s module layering (tissue/LAYERS.txt) as checked by scripts/check-layering.sh: the
// source tree passes, and a copy with one injected violation of each kind fails.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "support/test_data.h"
#include "support/tsf_process.h"

namespace {
namespace fs = std::filesystem;
using tsf::test::ProcessRun;

ProcessRun check_layering(const fs::path& root, const fs::path& scratch) {
  const fs::path script = tsf::test::source_dir() / "scripts" / "check-layering.sh";
  return tsf::test::run_logged(
      "bash " + tsf::test::shell_quoted(script) + " " + tsf::test::shell_quoted(root),
      scratch / "check-layering.log");
}

/// A copy of the checked part of the source tree (tissue/ sources, headers, CMake files and
/// LAYERS.txt) under `scratch`/root.
fs::path copy_of_tissue(const fs::path& scratch) {
  const fs::path from = tsf::test::source_dir() / "tissue";
  const fs::path root = scratch / "root";
  fs::create_directories(root / "tissue");
  for (const char* part : {"include", "src"})
    fs::copy(from / part, root / "tissue" / part, fs::copy_options::recursive);
  for (const char* file : {"LAYERS.txt", "CMakeLists.txt"})
    fs::copy_file(from / file, root / "tissue" / file);
  return root;
}

void append_line(const fs::path& file, const std::string& line) {
  std::ofstream out(file, std::ios::app);
  out << "\n" << line << "\n";
  ASSERT_TRUE(out.good()) << file;
}

/// The check fails on the copy once `line` is appended to tissue/`file`, naming the file.
void expect_violation(const std::string& name, const std::string& file, const std::string& line,
                      const std::string& says) {
  const fs::path scratch = tsf::test::scratch_dir(name);
  const fs::path root = copy_of_tissue(scratch);
  const ProcessRun clean = check_layering(root, scratch);
  ASSERT_EQ(clean.status, 0) << "the unmodified copy should pass:\n" << clean.output;
  append_line(root / "tissue" / file, line);
  const ProcessRun run = check_layering(root, scratch);
  EXPECT_EQ(run.status, 1) << line << " in " << file << " should fail the check:\n" << run.output;
  EXPECT_NE(run.output.find("tissue/" + file), std::string::npos) << run.output;
  EXPECT_NE(run.output.find(says), std::string::npos) << run.output;
}

}  // namespace

TEST(TissueLayering, IncludesFollowDeclaredModuleDependencies) {
  const fs::path scratch = tsf::test::scratch_dir("source");
  const ProcessRun run = check_layering(tsf::test::source_dir(), scratch);
  EXPECT_EQ(run.status, 0) << run.output;
  EXPECT_NE(run.output.find("follow tissue/LAYERS.txt"), std::string::npos) << run.output;
}

TEST(TissueLayering, CheckFailsOnAnUpwardModuleInclude) {
  // imt sits below interaction: the render surface must not know the interactive model.
  expect_violation("upward", "src/imt/mesh_quality.cpp", "#include \"tsf/interaction/tool.h\"",
                   "imt includes tsf/interaction/tool.h");
}

TEST(TissueLayering, CheckFailsOnAnExternalLibraryInclude) {
  expect_violation("vtk", "include/tsf/volume/voxel_box.h", "#include <vtkPolyData.h>",
                   "must not use ITK, VTK");
  expect_violation("yaml", "src/io/mesh_sequence.cpp", "#include <yaml-cpp/yaml.h>",
                   "must not use ITK, VTK");
}

TEST(TissueLayering, CheckFailsOnAnOuterLayerInclude) {
  expect_violation("import", "src/common/progress.cpp",
                   "#include \"tsf/import/volume_statistics.h\"",
                   "never includes the import, segment, export, viewer or app layers");
}

TEST(TissueLayering, CheckFailsOnACycleInTheDeclaredTable) {
  // volume -> haptics -> interaction -> ... -> volume.
  const fs::path scratch = tsf::test::scratch_dir("cycle");
  const fs::path root = copy_of_tissue(scratch);
  std::string table = tsf::test::read_text(root / "tissue" / "LAYERS.txt");
  const std::string from = "\nvolume: common", to = "\nvolume: common haptics";
  const auto at = table.find(from);
  ASSERT_NE(at, std::string::npos) << table;
  table.replace(at, from.size(), to);
  std::ofstream(root / "tissue" / "LAYERS.txt", std::ios::trunc) << table;
  const ProcessRun run = check_layering(root, scratch);
  EXPECT_EQ(run.status, 1) << run.output;
  EXPECT_NE(run.output.find("lead back to it (a cycle)"), std::string::npos) << run.output;
}
