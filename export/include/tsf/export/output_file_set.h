// Several output files that appear together or not at all (an OBJ and its .mtl, a sequence of
// numbered files and its animated glTF).
//
// add() writes each file at once to a temporary beside its target (same directory, so rename()
// is atomic), keeping memory to one file at a time; commit() first checks that every target can
// be replaced (its directory exists and is writable, it is not a directory), then renames the
// temporaries into place. If anything fails before commit() returns, every temporary is removed
// and so is every target this commit already moved into place: a failed export leaves none of
// its files (a file it was replacing is gone only if the failure came between two renames, after
// the checks passed). Destroying an uncommitted set removes its temporaries.
#pragma once

#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

namespace tsf::exporter {

class OutputFileSet {
 public:
  OutputFileSet() = default;
  ~OutputFileSet();
  OutputFileSet(const OutputFileSet&) = delete;
  OutputFileSet& operator=(const OutputFileSet&) = delete;

  /// Writes `bytes` to a temporary for `target` (creating missing parent directories). Throws
  /// tsf::Error naming `target` (and leaves nothing) when that fails or `target` is already in
  /// the set.
  void add(const std::filesystem::path& target, std::string_view bytes);
  /// Moves every file into place. Throws tsf::Error naming the file that failed and why.
  void commit();

  struct Entry {
    std::filesystem::path target, temporary;
    std::uintmax_t bytes = 0;
  };
  const std::vector<Entry>& entries() const { return entries_; }

 private:
  void discard() noexcept;
  std::vector<Entry> entries_;
  bool committed_ = false;
};

}  // namespace tsf::exporter
