#include "tsf/common/atomic_file.h"

#include <unistd.h>

#include <atomic>
#include <cstring>
#include <fstream>
#include <random>
#include <system_error>

#include "tsf/common/error.h"

namespace tsf {
namespace fs = std::filesystem;

namespace {

/// The temporaries being written, for remove_pending_temporaries (read from a signal handler:
/// fixed storage, lock-free atomics). A slot is free (0), being filled (1) or holds a path (2).
constexpr int kPendingSlots = 64;
constexpr std::size_t kPendingPathBytes = 4096;
struct PendingSlot {
  std::atomic<int> state{0};
  char path[kPendingPathBytes];
};
PendingSlot g_pending[kPendingSlots];

}  // namespace

int register_pending_temporary(const fs::path& temp) {
  const std::string s = temp.string();
  if (s.size() >= kPendingPathBytes) return -1;
  for (int i = 0; i < kPendingSlots; ++i) {
    int expected = 0;
    if (!g_pending[i].state.compare_exchange_strong(expected, 1)) continue;
    std::memcpy(g_pending[i].path, s.c_str(), s.size() + 1);
    g_pending[i].state.store(2);
    return i;
  }
  return -1;
}

void release_pending_temporary(int slot) {
  if (slot >= 0 && slot < kPendingSlots) g_pending[slot].state.store(0);
}

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
  const int slot = register_pending_temporary(temp);
  try {
    write(temp);
  } catch (...) {
    fs::remove(temp, ec);
    release_pending_temporary(slot);
    throw;
  }
  if (!fs::exists(temp)) {
    release_pending_temporary(slot);
    throw Error("writer produced no file for output '" + target.string() + "'");
  }
  fs::rename(temp, target, ec);
  release_pending_temporary(slot);
  if (ec) {
    std::error_code ignored;
    fs::remove(temp, ignored);
    throw Error("cannot move finished output into place as '" + target.string() +
                "': " + ec.message());
  }
}

void remove_pending_temporaries() noexcept {
  for (PendingSlot& slot : g_pending)
    if (slot.state.load() == 2) ::unlink(slot.path);
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
