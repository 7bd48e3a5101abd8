#include "support/tsf_process.h"

#include <sys/wait.h>

#include <array>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>

namespace tsf::test {

namespace fs = std::filesystem;

fs::path tsf_executable_path() {
  std::error_code ec;
  const fs::path self = fs::read_symlink("/proc/self/exe", ec);
  if (ec) return {};
  return self.parent_path().parent_path() / "bin" / "tsf";
}

std::optional<fs::path> tsf_executable() {
  const fs::path exe = tsf_executable_path();
  std::error_code ec;
  if (!exe.empty() && fs::is_regular_file(exe, ec)) return exe;
  return std::nullopt;
}

ProcessRun run_tsf(const fs::path& exe, const std::string& args) {
  ProcessRun r;
  const std::string command = shell_quoted(exe) + " " + args + " 2>&1";
  FILE* pipe = popen(command.c_str(), "r");
  if (!pipe) return r;
  std::array<char, 4096> buf{};
  std::size_t n;
  while ((n = fread(buf.data(), 1, buf.size(), pipe)) > 0) r.output.append(buf.data(), n);
  const int status = pclose(pipe);
  r.status = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return r;
}

ProcessRun run_logged(const std::string& command, const fs::path& log) {
  ProcessRun r;
  const int rc = std::system((command + " > " + log.string() + " 2>&1").c_str());
  r.status = WIFEXITED(rc) ? WEXITSTATUS(rc) : -1;
  r.output = read_text(log);
  return r;
}

std::string read_text(const fs::path& file) {
  std::ifstream f(file, std::ios::binary);
  std::stringstream s;
  s << f.rdbuf();
  return s.str();
}

std::string shell_quoted(const fs::path& path) {
  return "'" + path.string() + "'";
}

}  // namespace tsf::test
