#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <csignal>
#include <fstream>

#include "support/test_data.h"
#include "tsf/common/atomic_file.h"
#include "tsf/common/error.h"

namespace tsf {
namespace {
namespace fs = std::filesystem;

std::string read_all(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

TEST(AtomicFile, FailedWriterLeavesNoFileAndKeepsOldContents) {
  const fs::path dir = test::scratch_dir("atomic");
  const fs::path target = dir / "out.json";
  write_text_atomically(target, "old");
  EXPECT_THROW(write_file_atomically(target,
                                     [](const fs::path& tmp) {
                                       std::ofstream(tmp) << "half";
                                       throw Error("writer failed");
                                     }),
               Error);
  EXPECT_EQ(read_all(target), "old");
  int entries = 0;
  for ([[maybe_unused]] const auto& e : fs::directory_iterator(dir)) ++entries;
  EXPECT_EQ(entries, 1) << "a temporary file was left behind";
}

TEST(AtomicFile, CreatesParentsAndKeepsExtensionForFormatDetection) {
  const fs::path dir = test::scratch_dir("atomic2");
  const fs::path target = dir / "a" / "b" / "vol.nrrd";
  fs::path seen;
  write_file_atomically(target, [&](const fs::path& tmp) {
    seen = tmp;
    std::ofstream(tmp) << "x";
  });
  EXPECT_EQ(seen.extension(), ".nrrd");
  EXPECT_EQ(seen.parent_path(), target.parent_path());
  EXPECT_EQ(read_all(target), "x");
}

extern "C" void remove_and_end(int sig) {
  remove_pending_temporaries();
  std::signal(sig, SIG_DFL);
  std::raise(sig);
}

TEST(AtomicFile, ASignalDuringAWriteLeavesNoTemporaryWhenItsHandlerRemovesThem) {
  const fs::path dir = test::scratch_dir("atomic-signal");
  int ready[2];
  ASSERT_EQ(::pipe(ready), 0);
  const pid_t pid = ::fork();
  if (pid == 0) {
    // The child writes slowly, as a large volume would, with the handler tsf installs.
    std::signal(SIGTERM, remove_and_end);
    write_file_atomically(dir / "volume.nrrd", [&](const fs::path& tmp) {
      std::ofstream(tmp) << "half a volume";
      [[maybe_unused]] const ssize_t n = ::write(ready[1], "x", 1);
      ::pause();
    });
    _exit(0);
  }
  char c = 0;
  ASSERT_EQ(::read(ready[0], &c, 1), 1);  // the temporary exists now
  int files = 0;
  for ([[maybe_unused]] const auto& e : fs::directory_iterator(dir)) ++files;
  EXPECT_EQ(files, 1);
  ::kill(pid, SIGTERM);
  int status = 0;
  ::waitpid(pid, &status, 0);
  EXPECT_TRUE(WIFSIGNALED(status) && WTERMSIG(status) == SIGTERM);
  EXPECT_TRUE(fs::is_empty(dir)) << "the temporary or a half-written volume was left behind";
  ::close(ready[0]);
  ::close(ready[1]);
}

}  // namespace
}  // namespace tsf
