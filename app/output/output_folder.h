// Where a command writes: one output folder per run. Everything the run writes goes under it
// (scene `outputs:` are names inside it), so a run never writes into the checkout or beside the
// scene, and two runs never mix their files silently:
//   - a missing folder is created; an empty one is used;
//   - a non-empty folder is refused, unless --force and the folder holds the marker file a tsf
//     run leaves (`.tsf-run`): then the previous run's files are removed first. A folder of other
//     files is never emptied.
// Paths the run reports are absolute (a report read from another folder still finds its files).
#pragma once

#include <filesystem>
#include <string>

namespace tsf::app {

class OutputFolder {
 public:
  OutputFolder() = default;
  /// Prepares `folder` for a run of `command` (e.g. "tsf run"); `option` names the command-line
  /// option that chose it, for errors ("--out"). Throws tsf::Error naming the folder.
  static OutputFolder prepare(const std::filesystem::path& folder, bool force,
                              const std::string& option);

  const std::filesystem::path& path() const { return path_; }
  bool empty() const { return path_.empty(); }
  /// `name` (relative) inside the folder, absolute. Empty name → empty path. A name that would
  /// leave the folder (absolute, or climbing with `..`) throws tsf::Error naming it.
  std::filesystem::path file(const std::filesystem::path& name) const;

 private:
  std::filesystem::path path_;
};

/// A scene file may choose its run's output folder (`key`, e.g. pipeline.outputs.folder), but only
/// inside the working folder tsf runs in: a scene from elsewhere cannot make tsf create folders
/// and write files anywhere on the disk; `-o DIR` on the command line may. Throws tsf::Error
/// naming the scene file, the key and both folders; links are followed for the part that exists.
void check_scene_output_folder(const std::filesystem::path& folder, const std::string& key,
                               const std::filesystem::path& scene_file);

/// `path` made absolute (lexically normal); empty stays empty.
std::filesystem::path absolute_path(const std::filesystem::path& path);

}  // namespace tsf::app
