#include "support/test_data.h"

#include <unistd.h>

#include <cstdlib>
#include <mutex>
#include <vector>

namespace tsf::test {
namespace fs = std::filesystem;

fs::path source_dir() {
  return fs::path(TSF_SOURCE_DIR);
}

fs::path samples_dir() {
  return source_dir() / "data-samples";
}

std::optional<fs::path> shared_data_dir() {
  if (const char* env = std::getenv("TSF_SHARED_DATA"); env && *env) {
    if (fs::is_directory(env)) return fs::path(env);
    return std::nullopt;
  }
  const fs::path p = source_dir().parent_path() / "shared" / "data";
  if (fs::is_directory(p)) return p;
  return std::nullopt;
}

namespace {
std::mutex scratch_mutex;
std::vector<fs::path> scratch_dirs;
void remove_scratch_dirs() {
  std::error_code ec;
  for (const auto& d : scratch_dirs) fs::remove_all(d, ec);
}
}  // namespace

fs::path scratch_dir(const std::string& name) {
  std::lock_guard<std::mutex> lock(scratch_mutex);
  // TSF_KEEP_SCRATCH=1 keeps a test's files to look at after it ran.
  const char* keep = std::getenv("TSF_KEEP_SCRATCH");
  if (scratch_dirs.empty() && !(keep && *keep)) std::atexit(remove_scratch_dirs);
  const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
  std::string tag = name;
  if (info) tag = std::string(info->test_suite_name()) + "." + info->name() + "." + name;
  const fs::path dir =
      fs::temp_directory_path() / ("tsf-test-" + std::to_string(::getpid()) + "-" + tag);
  fs::remove_all(dir);
  fs::create_directories(dir);
  scratch_dirs.push_back(dir);
  return dir;
}

}  // namespace tsf::test
