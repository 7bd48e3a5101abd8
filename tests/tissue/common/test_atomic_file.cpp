#include <gtest/gtest.h>

#include <fstream>

#include "support/test_data.h"
#include "tsf/common/atomic_file.h"
#include "tsf/common/error.h"

namespace tsf {
namespace {
namespace fs = std::filesystem;

std::string read_all(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

TEST(AtomicFile, FailedWriterLeavesNoFileAndKeepsOldContents) {
  const fs::path dir = test::scratch_dir("atomic");
  const fs::path target = dir / "out.json";
  write_text_atomically(target, "old");
  EXPECT_THROW(write_file_atomically(target,
                                     [](const fs::path& tmp) {
                                       std::ofstream(tmp) << "half";
                                       throw Error("writer failed");
                                     }),
               Error);
  EXPECT_EQ(read_all(target), "old");
  int entries = 0;
  for ([[maybe_unused]] const auto& e : fs::directory_iterator(dir)) ++entries;
  EXPECT_EQ(entries, 1) << "a temporary file was left behind";
}

TEST(AtomicFile, CreatesParentsAndKeepsExtensionForFormatDetection) {
  const fs::path dir = test::scratch_dir("atomic2");
  const fs::path target = dir / "a" / "b" / "vol.nrrd";
  fs::path seen;
  write_file_atomically(target, [&](const fs::path& tmp) {
    seen = tmp;
    std::ofstream(tmp) << "x";
  });
  EXPECT_EQ(seen.extension(), ".nrrd");
  EXPECT_EQ(seen.parent_path(), target.parent_path());
  EXPECT_EQ(read_all(target), "x");
}

}  // namespace
}  // namespace tsf
