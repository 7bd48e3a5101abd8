// Finding the bundled files of a source checkout (materials/, scenes/, data-samples/) so that
// `tsf run` with no arguments works from the repository root, from a build folder, or anywhere
// else the tsf binary is started from inside the checkout.
#pragma once

#include <filesystem>
#include <string>

namespace tsf::app {

/// `relative` in a tsf source checkout holding the working directory (a folder with
/// scenes/sinus.yaml), else installed with the executable (EXE/../share/tsf/relative; a build
/// tree links it, cmake/TsfInstall.cmake). Throws tsf::Error naming what was searched for and
/// where.
std::filesystem::path find_bundled_path(const std::filesystem::path& relative);

}  // namespace tsf::app
