// The registry of knob studies of the accuracy-vs-time report (docs/accuracy-vs-time.md).
//
// A knob study varies one accuracy knob of the product (lattice spacing, time step, integrator,
// angular form, IMT resolution, …), measures for every setting the error against a reference and
// the time it costs in the same run, and returns tables, one plot and a findings paragraph written
// from the numbers. Each study lives in its own study_<id>.cpp and registers itself:
//
//   TSF_REGISTER_KNOB_STUDY(kCouplerStudy, {
//       "coupler-mode", "Coupler: local frame vs trilinear",
//       "coupler interpolation",
//       "the lattice's trilinear displacement field at each vertex",
//       "coupling time per vertex (median)", 75, run_coupler_study});
//
// bench/accuracy/CMakeLists.txt compiles every study_*.cpp into the report app, so adding a file
// adds a section, a plot and JSON rows to the report (docs/accuracy-vs-time.md, "Adding a knob
// study").
#pragma once

#include <functional>
#include <string>
#include <utility>
#include <vector>

namespace tsf::accuracy {

struct RunOptions {
  bool quick = false;  ///< CI-sized problems (seconds), same code paths
  int repeats = 5;     ///< timing repeats; times are medians
  int threads = 1;     ///< OpenMP threads the solvers use (printed in the report)
};

/// One setting of the knob: the table cells as printed, plus its raw errors and times (JSON;
/// every error must be finite, --verify checks it).
struct StudyRow {
  std::vector<std::string> cells;
  std::vector<std::pair<std::string, double>> errors;
  std::vector<std::pair<std::string, double>> times_s;
};

struct StudyTable {
  std::string caption;  ///< one line above the table (markdown)
  std::vector<std::string> columns;
  std::vector<StudyRow> rows;
};

struct PlotPoint {
  double x = 0, y = 0;
  std::string label;  ///< printed beside the point (the knob value)
};
struct PlotSeries {
  std::string name;
  std::vector<PlotPoint> points;
  bool lines = true;  ///< join the points (a knob sweep) or scatter them
};
struct PlotSpec {
  std::string x_label = "time (s)";
  std::string y_label = "relative error";
  bool log_x = true, log_y = true;
  std::vector<PlotSeries> series;
};

/// A line of the report's summary table: the settings that matter most, with their error and
/// time as printed.
struct KeyRow {
  std::string setting, error, time;
};

/// A property the study's numbers must have (the finer setting beats the coarsest, a measured lag
/// matches its formula, …): printed in the report, written to the JSON, and a failed one makes
/// --verify (the AccuracyReport.* ctest) fail.
struct StudyCheck {
  std::string claim;  ///< what must hold, as printed
  bool passed = false;
  std::string detail;  ///< the numbers compared
};

struct StudyResult {
  std::vector<StudyTable> tables;
  PlotSpec plot;
  std::string findings;  ///< markdown paragraph(s) that read the numbers
  std::vector<KeyRow> key_rows;
  std::vector<StudyCheck> checks;
};

struct KnobStudy {
  std::string id;            ///< file stem: docs/images/accuracy-<id>.png; [a-z0-9-]
  std::string title;         ///< section title
  std::string knob;          ///< what is varied
  std::string reference;     ///< what the error is measured against
  std::string time_measure;  ///< what the time columns measure
  int order = 100;           ///< position in the report, ascending
  std::function<StudyResult(const RunOptions&)> run;
};

/// Adds a study (returns true so it can initialise a static); a duplicate id is a fatal error at
/// report start.
bool register_study(KnobStudy study);
/// Every registered study, sorted by order then id.
std::vector<KnobStudy> registered_studies();

/// Number formatting shared by the studies: significant digits, percentages, durations.
std::string format_number(double value, int significant = 3);
std::string format_percent(double fraction, int significant = 3);
std::string format_seconds(double seconds);

}  // namespace tsf::accuracy

#define TSF_REGISTER_KNOB_STUDY(variable, ...) \
  static const bool variable = ::tsf::accuracy::register_study(__VA_ARGS__)
