// The report of a `tsf run`: Markdown with PNG plots (gnuplot) written next to the JSON report.
//   run-report.md          stages, rates, energy, tool force, effects, outputs
//   images/run-*.png       time per stage, energy over time, tool force over time
// Plots are skipped (and the report says so) when gnuplot is missing.
#pragma once

#include <filesystem>

#include <nlohmann/json.hpp>

namespace tsf::app {

/// Writes `folder`/run-report.md and its plots from the run's JSON report; returns the
/// markdown path. `plots` false: no gnuplot.
std::filesystem::path write_run_report(const nlohmann::json& report,
                                       const std::filesystem::path& folder, bool plots);

}  // namespace tsf::app
