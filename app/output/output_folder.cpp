#include "output/output_folder.h"

#include <fstream>
#include <system_error>

#include "tsf/common/error.h"

namespace tsf::app {
namespace fs = std::filesystem;

namespace {
constexpr const char* kMarker = ".tsf-run";
}

fs::path absolute_path(const fs::path& path) {
  if (path.empty()) return path;
  std::error_code ec;
  const fs::path a = fs::absolute(path, ec);
  return (ec ? path : a).lexically_normal();
}

OutputFolder OutputFolder::prepare(const fs::path& folder, bool force, const std::string& option) {
  if (folder.empty()) throw Error(option + ": expected an output folder");
  OutputFolder out;
  out.path_ = absolute_path(folder);
  std::error_code ec;
  if (fs::exists(out.path_, ec) && !fs::is_directory(out.path_, ec))
    throw Error(option + ": " + out.path_.string() + " exists and is not a folder");
  if (fs::is_directory(out.path_, ec) && !fs::is_empty(out.path_, ec)) {
    const bool ours = fs::exists(out.path_ / kMarker, ec);
    if (!force)
      throw Error(option + ": " + out.path_.string() +
                  " is not empty: choose a new folder, or pass --force to replace " +
                  (ours ? "the earlier run's files" : "(only a folder an earlier tsf run wrote)"));
    if (!ours)
      throw Error(option + ": " + out.path_.string() + " holds files that no tsf run wrote (no " +
                  kMarker +
                  " marker): --force empties only an earlier run's folder; choose a new folder");
    for (const fs::directory_entry& e : fs::directory_iterator(out.path_)) fs::remove_all(e, ec);
    if (ec) throw Error(option + ": cannot empty " + out.path_.string() + ": " + ec.message());
  }
  fs::create_directories(out.path_, ec);
  if (ec) throw Error(option + ": cannot create " + out.path_.string() + ": " + ec.message());
  std::ofstream marker(out.path_ / kMarker);
  marker << "written by tsf; `--force` may empty this folder\n";
  if (!marker) throw Error(option + ": cannot write into " + out.path_.string());
  return out;
}

fs::path OutputFolder::file(const fs::path& name) const {
  if (name.empty()) return {};
  return (path_ / name).lexically_normal();
}

}  // namespace tsf::app
