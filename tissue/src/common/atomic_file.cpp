#include "tsf/common/atomic_file.h"

#include <atomic>
#include <fstream>
#include <random>
#include <system_error>

#include "tsf/common/error.h"

namespace tsf {
namespace fs = std::filesystem;

namespace {
fs::path temporary_beside(const fs::path& target) {
  static std::atomic<unsigned> counter{0};
  std::random_device rd;
  const std::string stem = target.stem().string();
  const std::string tag = std::to_string(rd() & 0xffffffu) + "-" + std::to_string(counter++);
  // Keep the extension last: writers such as ITK pick the file format from it.
  return target.parent_path() / ("." + stem + ".tmp-" + tag + target.extension().string());
}
}  // namespace

void write_file_atomically(const fs::path& target,
                           const std::function<void(const fs::path& temp_path)>& write) {
  std::error_code ec;
  if (target.has_parent_path()) {
    fs::create_directories(target.parent_path(), ec);
    if (ec)
      throw Error("cannot create directory '" + target.parent_path().string() + "' for output '" +
                  target.string() + "': " + ec.message());
  }
  const fs::path temp = temporary_beside(target);
  try {
    write(temp);
  } catch (...) {
    fs::remove(temp, ec);
    throw;
  }
  if (!fs::exists(temp))
    throw Error("writer produced no file for output '" + target.string() + "'");
  fs::rename(temp, target, ec);
  if (ec) {
    std::error_code ignored;
    fs::remove(temp, ignored);
    throw Error("cannot move finished output into place as '" + target.string() +
                "': " + ec.message());
  }
}

void write_text_atomically(const fs::path& target, const std::string& contents) {
  write_file_atomically(target, [&](const fs::path& temp) {
    std::ofstream out(temp, std::ios::binary | std::ios::trunc);
    if (!out) throw Error("cannot open '" + temp.string() + "' for writing");
    out.write(contents.data(), static_cast<std::streamsize>(contents.size()));
    out.flush();
    if (!out) throw Error("write failed for '" + target.string() + "' (disk full?)");
  });
}

}  // namespace tsf
