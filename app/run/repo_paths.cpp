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
  // A source checkout holding the working folder first (a developer's edits), then the files
  // installed with the executable (PREFIX/bin/tsf -> PREFIX/share/tsf; a build tree links
  // BUILD/share/tsf to the checkout: cmake/TsfInstall.cmake).
  std::vector<fs::path> tried;
  for (fs::path dir = fs::current_path();; dir = dir.parent_path()) {
    std::error_code ec;
    if (fs::exists(dir / relative, ec) && fs::exists(dir / "scenes" / "sinus.yaml", ec))
      return dir / relative;
    if (dir == dir.root_path() || dir.parent_path() == dir) break;
  }
  tried.push_back(fs::current_path() / "(and its parent folders)");
  if (const fs::path exe = executable_folder(); !exe.empty()) {
    const fs::path installed = exe.parent_path() / "share" / "tsf" / relative;
    std::error_code ec;
    if (fs::exists(installed, ec)) return installed;
    tried.push_back(installed);
  }
  std::string where;
  for (const fs::path& t : tried) where += (where.empty() ? "" : ", ") + t.string();
  throw Error("cannot find the bundled '" + relative.string() + "' (looked in " + where +
              "): run the tsf of an installation (PREFIX/bin/tsf with PREFIX/share/tsf) or of a "
              "build tree, or from a tsf source checkout, or give the path");
}

}  // namespace tsf::app
