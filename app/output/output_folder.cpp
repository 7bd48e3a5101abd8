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

namespace {
/// Whether `inner` is `outer` or below it (both absolute and normal).
bool is_inside(const fs::path& inner, const fs::path& outer) {
  const fs::path rel = inner.lexically_relative(outer);
  return !rel.empty() && *rel.begin() != ".." && !rel.is_absolute();
}
}  // namespace

fs::path OutputFolder::file(const fs::path& name) const {
  if (name.empty()) return {};
  const fs::path p = (path_ / name).lexically_normal();
  if (name.is_absolute() || !is_inside(p, path_) || p == path_)
    throw Error("output '" + name.string() + "' would be written outside the output folder " +
                path_.string() + ": outputs are names inside it");
  return p;
}

void check_scene_output_folder(const fs::path& folder, const std::string& key,
                               const fs::path& scene_file) {
  std::error_code ec;
  const fs::path here = fs::weakly_canonical(fs::current_path(ec), ec);
  const fs::path chosen = fs::weakly_canonical(absolute_path(folder), ec);
  if (ec || !is_inside(chosen.lexically_normal(), here.lexically_normal()) || chosen == here)
    throw Error(scene_file.string() + ": " + key + ": '" + folder.string() + "' (" +
                chosen.string() + ") is not a folder inside the working folder " + here.string() +
                ": a scene may choose its output folder only there; give -o DIR to write "
                "elsewhere");
}

}  // namespace tsf::app
