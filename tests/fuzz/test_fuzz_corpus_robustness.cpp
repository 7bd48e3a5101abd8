// Replays every file of the fuzz corpora (fuzz/corpus/<target>: seeds; fuzz/regressions/<target>:
// every input a campaign found crashing, hanging or ballooning, kept after the fix) through the
// fuzz targets (fuzz/fuzz_targets.h). Each must give a result or a tsf::Error: under ASan + UBSan
// in CI (the suite name contains "Robustness") a memory error or undefined behaviour fails it.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "fuzz_targets.h"
#include "support/test_data.h"

namespace tsf::fuzz {
namespace {
namespace fs = std::filesystem;

/// Feeds each file under <source>/fuzz/<kind>/<target> to the target; the number of files.
int replay(const std::string& kind, const std::string& target) {
  const Target run = find_target(target);
  EXPECT_NE(run, nullptr) << target;
  const fs::path dir = test::source_dir() / "fuzz" / kind / target;
  if (!run || !fs::is_directory(dir)) return 0;
  std::vector<fs::path> files;
  for (const auto& e : fs::directory_iterator(dir))
    if (e.is_regular_file() && e.path().filename().string()[0] != '.') files.push_back(e.path());
  std::sort(files.begin(), files.end());
  for (const fs::path& f : files) {
    std::ifstream in(f, std::ios::binary);
    const std::vector<std::uint8_t> bytes((std::istreambuf_iterator<char>(in)),
                                          std::istreambuf_iterator<char>());
    try {
      run(bytes.data(), bytes.size());
    } catch (const std::exception& e) {
      ADD_FAILURE() << f << ": an exception other than tsf::Error escaped: " << e.what();
    }
  }
  return static_cast<int>(files.size());
}

TEST(FuzzCorpusRobustness, EverySeedGivesAResultOrAClearError) {
  for (const std::string& target : target_names())
    EXPECT_GE(replay("corpus", target), 1) << "fuzz/corpus/" << target << " has no seed";
}

TEST(FuzzCorpusRobustness, EveryRegressionInputGivesAResultOrAClearError) {
  int total = 0;
  for (const std::string& target : target_names()) total += replay("regressions", target);
  RecordProperty("regression_inputs", total);
}

}  // namespace
}  // namespace tsf::fuzz
