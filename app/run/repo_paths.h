// Finding the bundled files of a source checkout (materials/, scenes/, data-samples/) so that
// `tsf run` with no arguments works from the repository root, from a build folder, or anywhere
// else the tsf binary is started from inside the checkout.
#pragma once

#include <filesystem>
#include <string>

namespace tsf::app {

/// The first existing `relative` under the working directory or the executable's folder, or any
/// of their parents. Throws tsf::Error naming what was searched for and where.
std::filesystem::path find_bundled_path(const std::filesystem::path& relative);

}  // namespace tsf::app
