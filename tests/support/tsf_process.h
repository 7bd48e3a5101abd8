// Running the `tsf` executable of this build from a test: where it is, a skip when it is not
// built (TSF_BUILD_APP=OFF), and one run with its exit status and output.
#pragma once

#include <gtest/gtest.h>

#include <filesystem>
#include <optional>
#include <string>

namespace tsf::test {

/// <build>/bin/tsf next to <build>/tests/<this test executable>; the file may not exist.
std::filesystem::path tsf_executable_path();

/// tsf_executable_path() when that file exists.
std::optional<std::filesystem::path> tsf_executable();

struct ProcessRun {
  int status = -1;     ///< exit status; -1 when it did not exit normally or could not start
  std::string output;  ///< stdout and stderr together
};

/// Runs `'exe' args 2>&1` through the shell (args are shell text: quote paths with
/// shell_quoted) and collects its output.
ProcessRun run_tsf(const std::filesystem::path& exe, const std::string& args);

/// Runs a shell command with stdout and stderr written to `log` (kept for a failing test's
/// reader); its exit status and that output.
ProcessRun run_logged(const std::string& command, const std::filesystem::path& log);

/// The whole text of a file ("" when it cannot be read).
std::string read_text(const std::filesystem::path& file);

/// A path in single quotes for the shell command of run_tsf.
std::string shell_quoted(const std::filesystem::path& path);

}  // namespace tsf::test

/// Declares `const std::filesystem::path var` = the tsf executable, or skips the test saying why.
#define TSF_EXECUTABLE_OR_SKIP(var)                                                              \
  const auto var##_opt = ::tsf::test::tsf_executable();                                          \
  if (!var##_opt)                                                                                \
    GTEST_SKIP() << "not run: the tsf executable is not part of this build (TSF_BUILD_APP=OFF)"; \
  const std::filesystem::path var = *var##_opt
