#include "tsf/export/output_file_set.h"

#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstring>
#include <fstream>
#include <random>
#include <system_error>

#include "tsf/common/error.h"

namespace tsf::exporter {
namespace fs = std::filesystem;

namespace {

fs::path temporary_beside(const fs::path& target) {
  static std::atomic<unsigned> counter{0};
  std::random_device rd;
  const std::string tag = std::to_string(::getpid()) + "-" + std::to_string(rd() & 0xffffffu) +
                          "-" + std::to_string(counter++);
  // Keep the extension last so that anything sniffing the temporary sees the right type.
  return target.parent_path() /
         ("." + target.stem().string() + ".tmp-" + tag + target.extension().string());
}

fs::path directory_of(const fs::path& target) {
  return target.has_parent_path() ? target.parent_path() : fs::path(".");
}

}  // namespace

OutputFileSet::~OutputFileSet() {
  if (!committed_) discard();
}

void OutputFileSet::discard() noexcept {
  std::error_code ec;
  for (const Entry& e : entries_) fs::remove(e.temporary, ec);
  entries_.clear();
}

void OutputFileSet::add(const fs::path& target, std::string_view bytes) {
  require(!committed_, "output '" + target.string() + "' added to a set already committed");
  for (const Entry& e : entries_)
    require(fs::absolute(e.target) != fs::absolute(target),
            "output '" + target.string() + "' would be written twice by one export");
  std::error_code ec;
  if (target.has_parent_path()) {
    fs::create_directories(target.parent_path(), ec);
    if (ec)
      throw Error("cannot create directory '" + target.parent_path().string() + "' for output '" +
                  target.string() + "': " + ec.message());
  }
  Entry entry{target, temporary_beside(target), bytes.size()};
  {
    std::ofstream out(entry.temporary, std::ios::binary | std::ios::trunc);
    if (!out)
      throw Error("cannot write output '" + target.string() + "': cannot create a file in '" +
                  directory_of(target).string() + "' (" + std::strerror(errno) + ")");
    out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
    out.flush();
    if (!out) {
      out.close();
      fs::remove(entry.temporary, ec);
      throw Error("write failed for output '" + target.string() + "' (disk full?)");
    }
  }
  entries_.push_back(std::move(entry));
}

void OutputFileSet::commit() {
  require(!committed_, "output set committed twice");
  // Checks first, so that a doomed commit fails before any file moves.
  for (const Entry& e : entries_) {
    std::error_code ec;
    if (fs::is_directory(e.target, ec)) {
      const std::string message =
          "cannot write output '" + e.target.string() + "': a directory of that name exists";
      discard();
      throw Error(message);
    }
    if (::access(directory_of(e.target).c_str(), W_OK) != 0) {
      const std::string message = "cannot write output '" + e.target.string() + "': directory '" +
                                  directory_of(e.target).string() + "' is not writable";
      discard();
      throw Error(message);
    }
  }
  for (std::size_t i = 0; i < entries_.size(); ++i) {
    std::error_code ec;
    fs::rename(entries_[i].temporary, entries_[i].target, ec);
    if (ec) {
      const std::string message = "cannot move output '" + entries_[i].target.string() +
                                  "' into place: " + ec.message() +
                                  " (the files of this export were removed)";
      std::error_code ignored;
      for (std::size_t k = 0; k < i; ++k) fs::remove(entries_[k].target, ignored);
      for (std::size_t k = i; k < entries_.size(); ++k) fs::remove(entries_[k].temporary, ignored);
      entries_.clear();
      committed_ = true;
      throw Error(message);
    }
  }
  committed_ = true;
}

}  // namespace tsf::exporter
