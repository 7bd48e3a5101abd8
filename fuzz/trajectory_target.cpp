// The reader of haptic trajectory files, as `tsf haptics --trajectory` runs it: the reader is
// internal to app/cmd_haptics.cpp, so that file is compiled into this translation unit (and only
// here) and its reader called directly; nothing else of the command runs.
#include "cmd_haptics.cpp"  // NOLINT(bugprone-suspicious-include)

namespace tsf::fuzz {

void read_trajectory_for_fuzzing(const std::filesystem::path& file) {
  app::read_trajectory_file(file);
}

}  // namespace tsf::fuzz
