// Atomic file output: write to a temporary file beside the target, then rename over it.
//
// A failed or interrupted writer leaves no half-written target: either the old file (or none)
// or the complete new one. The temporary lives in the same directory so rename() is atomic on
// POSIX file systems.
#pragma once

#include <filesystem>
#include <functional>
#include <string>

namespace tsf {

/// Calls `write(temp_path)`, which must create and fill `temp_path`, then renames it to `target`.
/// If `write` throws, or the rename fails, the temporary is removed and a tsf::Error naming
/// `target` is thrown. The temporary keeps the target's extension (writers such as ITK choose
/// the format from it). Missing parent directories are created.
void write_file_atomically(
    const std::filesystem::path& target,
    const std::function<void(const std::filesystem::path& temp_path)>& write);

/// Writes `contents` to `target` atomically (text or binary bytes).
void write_text_atomically(const std::filesystem::path& target, const std::string& contents);

/// Registers a temporary file being written (write_file_atomically does so for its own), so that
/// remove_pending_temporaries removes it if a signal ends the process first. Returns the slot to
/// release once the file is renamed or removed; -1 when all 64 slots are taken.
int register_pending_temporary(const std::filesystem::path& temp);
void release_pending_temporary(int slot);

/// Removes the temporaries of writes still in progress. Async-signal-safe (unlink(2) only): a
/// SIGINT/SIGTERM handler calls it before the process ends, so an interrupted writer leaves no
/// hidden `.name.tmp-*` file behind.
void remove_pending_temporaries() noexcept;

}  // namespace tsf
