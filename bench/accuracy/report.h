// Output of the accuracy-vs-time report: the markdown document, one PNG plot per study (gnuplot,
// pngcairo), and a JSON file of every row (machine-readable, checked by --verify).
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "knob_study.h"

namespace tsf::accuracy {

/// Where and how the report was run: printed at the top of the markdown and in the JSON.
struct RunInfo {
  std::string date_utc;
  std::string commit;  ///< given on the command line (scripts/accuracy-report.sh passes git's)
  std::string cpu;
  int logical_cores = 0;
  int threads = 0;  ///< OpenMP threads used by the solvers
  std::string load_average_start, load_average_end;
  std::string compiler;
  bool quick = false;
  bool plots = true;  ///< false with --no-plots (no gnuplot): studies carry no PNG
  int repeats = 0;
  double total_seconds = 0;
  std::string command;            ///< the command line that produced the report
  std::vector<std::string> only;  ///< --only selection; empty = every registered study ran
};
RunInfo collect_run_info();

struct StudyOutcome {
  KnobStudy study;
  StudyResult result;
  double seconds = 0;              ///< wall time of the study (errors and timings)
  std::string failure;             ///< non-empty when the study threw: the report says so
  std::filesystem::path plot_png;  ///< written plot, empty when none
};

/// Writes <data_dir>/accuracy-<id>.dat/.gp and renders `png` with gnuplot. Returns false (and
/// says why on stderr) when gnuplot is missing or fails; the report then links no image.
bool write_plot(const KnobStudy& study, const StudyResult& result,
                const std::filesystem::path& data_dir, const std::filesystem::path& png);

void write_markdown(const std::filesystem::path& path, const RunInfo& info,
                    const std::vector<StudyOutcome>& outcomes);
void write_json(const std::filesystem::path& path, const RunInfo& info,
                const std::vector<StudyOutcome>& outcomes, const std::filesystem::path& markdown);

/// Re-reads a report's JSON: every study of `registered` present (unless the run used --only) and
/// not failed, every row's errors finite and times positive, every study check passed, the
/// markdown and every plot file present and non-empty. Prints each problem; returns the number
/// found.
int verify_report(const std::filesystem::path& json_path,
                  const std::vector<std::string>& registered);

}  // namespace tsf::accuracy
