// The `tsf` subcommands. Each lives in its own cmd_<name>.cpp and adds itself to the CLI11 app;
// a subcommand whose module was not built registers a stub that says which option enables it.
#pragma once

#include <CLI/CLI.hpp>

#include <string>

namespace tsf::app {

void add_import_command(CLI::App& app);    // cmd_import.cpp    (TSF_WITH_ITK)
void add_info_command(CLI::App& app);      // cmd_info.cpp      (TSF_WITH_ITK)
void add_segment_command(CLI::App& app);   // cmd_segment.cpp   (TSF_WITH_ITK)
void add_surface_command(CLI::App& app);   // cmd_surface.cpp
void add_simulate_command(CLI::App& app);  // cmd_simulate.cpp
void add_haptics_command(CLI::App& app);   // cmd_haptics.cpp
void add_export_command(CLI::App& app);    // cmd_export.cpp    (TSF_WITH_ASSIMP)
void add_view_command(CLI::App& app);      // cmd_view.cpp      (TSF_WITH_VTK)
void add_run_command(CLI::App& app);       // cmd_run.cpp
void add_link_command(CLI::App& app);      // cmd_link.cpp      (TSF_WITH_IGTL)

/// The manual page (roff) and the bash completion script, from the commands' definitions
/// (cmd_docs.cpp): `tsf --man`, `tsf --bash-completion`.
std::string man_page(const CLI::App& app);
std::string bash_completion(const CLI::App& app);

/// Registers `name` with a one-line description; running it fails with a message naming the
/// CMake option that builds it.
void add_unavailable_command(CLI::App& app, const char* name, const char* description,
                             const char* cmake_option);

}  // namespace tsf::app
