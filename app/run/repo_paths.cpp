// Bundled-file lookup (repo_paths.h).
#include "run/repo_paths.h"

#include <unistd.h>

#include <vector>

#include "tsf/common/error.h"

namespace tsf::app {
namespace fs = std::filesystem;

namespace {

fs::path executable_folder() {
  char buffer[4096];
  const ssize_t n = readlink("/proc/self/exe", buffer, sizeof(buffer) - 1);
  if (n <= 0) return {};
  buffer[n] = 0;
  return fs::path(buffer).parent_path();
}

}  // namespace

fs::path find_bundled_path(const fs::path& relative) {
  std::vector<fs::path> starts = {fs::current_path()};
  if (const fs::path exe = executable_folder(); !exe.empty()) starts.push_back(exe);
  std::string tried;
  for (const fs::path& start : starts) {
    for (fs::path dir = start;; dir = dir.parent_path()) {
      const fs::path candidate = dir / relative;
      std::error_code ec;
      if (fs::exists(candidate, ec)) return candidate;
      if (dir == dir.root_path() || dir.parent_path() == dir) break;
    }
    tried += (tried.empty() ? "" : " and ") + start.string();
  }
  throw Error("cannot find the bundled '" + relative.string() + "' (looked in " + tried +
              " and their parent folders; run from the tsf source checkout or give the path)");
}

}  // namespace tsf::app
