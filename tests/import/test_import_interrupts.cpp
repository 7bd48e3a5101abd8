// SIGINT and SIGTERM sent to a real `tsf import` process while it decodes: the decoders stop,
// the command exits 1 saying it was interrupted, and the output folder holds nothing (no volume,
// no sidecar, no hidden temporary). A decoder kept busy by the test hook
// TSF_TEST_DECODER_FAULT=sleep makes the moment certain.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <string>
#include <thread>
#include <vector>

#include "dicom_test_files.h"
#include "support/test_data.h"
#include "support/tsf_process.h"

namespace tsf::import {
namespace {
namespace fs = std::filesystem;

/// Starts `exe args` in a process group of its own, output to `log`, with `env` added.
pid_t start(const fs::path& exe, const std::vector<std::string>& args,
            const std::vector<std::string>& env, const fs::path& log) {
  const pid_t pid = ::fork();
  if (pid != 0) return pid;
  ::setpgid(0, 0);
  std::FILE* out = std::fopen(log.c_str(), "w");
  if (out) {
    ::dup2(::fileno(out), 1);
    ::dup2(::fileno(out), 2);
  }
  for (const std::string& e : env) ::putenv(const_cast<char*>(e.c_str()));
  std::vector<char*> argv{const_cast<char*>(exe.c_str())};
  for (const std::string& a : args) argv.push_back(const_cast<char*>(a.c_str()));
  argv.push_back(nullptr);
  ::execv(exe.c_str(), argv.data());
  _exit(127);
}

/// Waits at most `seconds` for `pid`; its wait status, or -1 (then it is killed).
int wait_for(pid_t pid, double seconds) {
  const auto until = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
  while (std::chrono::steady_clock::now() < until) {
    int status = 0;
    if (::waitpid(pid, &status, WNOHANG) == pid) return status;
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  ::kill(-pid, SIGKILL);
  int status = 0;
  ::waitpid(pid, &status, 0);
  return -1;
}

TEST(ImportInterruptRobustness, SigintOrSigtermStopsTheImportAndLeavesNothingBehind) {
  TSF_EXECUTABLE_OR_SKIP(tsf);
  const fs::path series = test::scratch_dir("interrupt-series");
  test_files::series_of_copies(test::source_dir() / "fuzz" / "corpus" / "dicom" / "j2k.dcm", series,
                               6);
  const std::vector<std::string> env{"TSF_TEST_DECODER_FAULT=sleep",
                                     "TSF_TEST_DECODER_FAULT_FILE=slice-2"};
  struct Case {
    int sig;
    bool to_group;  ///< as a terminal's Ctrl-C does: the decoders get it too
  };
  for (const Case c : {Case{SIGINT, true}, Case{SIGTERM, false}}) {
    const fs::path out = test::scratch_dir("interrupt-out-" + std::to_string(c.sig));
    const fs::path log = test::scratch_dir("interrupt-logs") / (std::to_string(c.sig) + ".txt");
    const pid_t pid = start(tsf,
                            {"import", series.string(), "-o", (out / "head.nrrd").string(),
                             "--no-progress", "--threads", "2"},
                            env, log);
    ASSERT_GT(pid, 0);
    // The headers take well under a second; then one decoder sleeps on slice-2.
    std::this_thread::sleep_for(std::chrono::seconds(3));
    ::kill(c.to_group ? -pid : pid, c.sig);
    const int status = wait_for(pid, 60);
    const std::string output = test::read_text(log);
    ASSERT_NE(status, -1) << "still running 60 s after signal " << c.sig << "\n" << output;
    ASSERT_TRUE(WIFEXITED(status)) << "signal " << c.sig << ": ended by a signal\n" << output;
    EXPECT_EQ(WEXITSTATUS(status), 1) << output;
    EXPECT_NE(
        output.find("interrupted (signal " + std::to_string(c.sig) + "): nothing was written"),
        std::string::npos)
        << output;
    std::vector<std::string> left;
    for (const auto& e : fs::directory_iterator(out)) left.push_back(e.path().filename().string());
    EXPECT_TRUE(left.empty()) << "signal " << c.sig << " left " << left.size() << " files, first "
                              << (left.empty() ? "" : left.front());
  }
}

}  // namespace
}  // namespace tsf::import
