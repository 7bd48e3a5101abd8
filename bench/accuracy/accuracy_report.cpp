// accuracy_report: runs every registered knob study (knob_study.h) and writes the
// accuracy-vs-time report — markdown, one PNG per study, JSON of every row.
//
//   accuracy_report --markdown docs/accuracy-vs-time.md --images docs/images --data build/acc
//   accuracy_report --quick --markdown build/acc/r.md --images build/acc --data build/acc
//   accuracy_report --verify build/acc/accuracy-vs-time.json
//
// scripts/accuracy-report.sh is the one command that regenerates docs/accuracy-vs-time.md.
#include <omp.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <set>

#include "knob_study.h"
#include "report.h"
#include "tsf/common/error.h"

namespace fs = std::filesystem;
using namespace tsf::accuracy;

int main(int argc, char** argv) {
  CLI::App app{
      "Accuracy vs time: for every accuracy knob of tsf, the error against a reference and the "
      "time it costs, measured in the same run (docs/accuracy-vs-time.md)."};
  bool quick = false, list = false, plots = true;
  int repeats = 0, threads = 0;
  std::string markdown = "accuracy-vs-time.md", images, data, commit, verify;
  std::vector<std::string> only;
  app.add_flag("--quick", quick, "CI-sized problems (about a minute for every study)");
  app.add_option("--markdown", markdown, "markdown report to write")->capture_default_str();
  app.add_option("--images", images, "folder for the PNG plots (default: the markdown's folder)");
  app.add_option("--data", data,
                 "folder for the JSON, plot data and gnuplot scripts (default: the markdown's "
                 "folder)");
  app.add_option("--only", only, "run only these study ids (repeatable)")->delimiter(',');
  app.add_option("--repeats", repeats, "timing repeats (median); default 5, quick 3")
      ->check(CLI::Range(1, 100));
  app.add_option("--threads", threads, "OpenMP threads (default: all)")->check(CLI::Range(1, 1024));
  app.add_option("--commit", commit, "commit id to print in the report");
  app.add_flag("!--no-plots", plots, "skip gnuplot");
  app.add_flag("--list", list, "list the registered studies and exit");
  app.add_option("--verify", verify,
                 "check a report's JSON (every study present, errors finite, files written) and "
                 "exit non-zero on a problem");
  CLI11_PARSE(app, argc, argv);

  try {
    const std::vector<KnobStudy> studies = registered_studies();
    std::set<std::string> ids;
    for (const auto& s : studies)
      if (!ids.insert(s.id).second)
        throw tsf::Error("two knob studies share the id '" + s.id + "'");
    if (list) {
      for (const auto& s : studies) std::printf("%-22s %s\n", s.id.c_str(), s.title.c_str());
      return 0;
    }
    if (!verify.empty()) {
      std::vector<std::string> registered;
      for (const auto& s : studies) registered.push_back(s.id);
      const int problems = verify_report(verify, registered);
      if (problems == 0) std::printf("accuracy report %s: OK\n", verify.c_str());
      return problems == 0 ? 0 : 1;
    }
    for (const auto& id : only)
      if (!ids.count(id)) throw tsf::Error("--only: no study '" + id + "' (see --list)");

    if (threads > 0) omp_set_num_threads(threads);
    RunOptions options;
    options.quick = quick;
    options.repeats = repeats > 0 ? repeats : (quick ? 3 : 5);
    options.threads = omp_get_max_threads();
    RunInfo info = collect_run_info();
    info.quick = quick;
    info.plots = plots;
    info.repeats = options.repeats;
    info.commit = commit;
    info.command = "accuracy_report";
    info.only = only;
    for (int i = 1; i < argc; ++i) info.command += " " + std::string(argv[i]);

    const fs::path md_path = fs::absolute(markdown);
    const fs::path image_dir = images.empty() ? md_path.parent_path() : fs::absolute(images);
    const fs::path data_dir = data.empty() ? md_path.parent_path() : fs::absolute(data);
    fs::create_directories(data_dir);
    fs::create_directories(image_dir);

    std::printf("accuracy report: %s mode, %d OpenMP threads, %d repeats, %s\n",
                quick ? "quick" : "full", options.threads, options.repeats, info.cpu.c_str());
    std::fflush(stdout);
    const auto start = std::chrono::steady_clock::now();
    std::vector<StudyOutcome> outcomes;
    int failures = 0, index = 0;
    const std::size_t total = only.empty() ? studies.size() : only.size();
    for (const auto& study : studies) {
      if (!only.empty() && std::find(only.begin(), only.end(), study.id) == only.end()) continue;
      ++index;
      std::printf("[%d/%zu] %s ...\n", index, total, study.id.c_str());
      std::fflush(stdout);
      StudyOutcome o;
      o.study = study;
      const auto t0 = std::chrono::steady_clock::now();
      try {
        o.result = study.run(options);
      } catch (const std::exception& e) {
        o.failure = e.what();
        ++failures;
        std::fprintf(stderr, "accuracy_report: study %s failed: %s\n", study.id.c_str(), e.what());
      }
      o.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      if (o.failure.empty()) {
        for (const auto& t : o.result.tables)
          for (const auto& r : t.rows)
            for (const auto& [name, value] : r.errors)
              if (!std::isfinite(value)) {
                std::fprintf(stderr, "accuracy_report: study %s: error '%s' is not finite\n",
                             study.id.c_str(), name.c_str());
                ++failures;
              }
        for (const auto& c : o.result.checks)
          if (!c.passed) {
            std::fprintf(stderr, "accuracy_report: study %s: check failed: %s (%s)\n",
                         study.id.c_str(), c.claim.c_str(), c.detail.c_str());
            ++failures;
          }
        const fs::path png = image_dir / ("accuracy-" + study.id + ".png");
        if (plots && write_plot(study, o.result, data_dir, png)) o.plot_png = png;
      }
      std::printf("      done in %.1f s\n", o.seconds);
      std::fflush(stdout);
      outcomes.push_back(std::move(o));
    }
    info.total_seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    info.load_average_end = collect_run_info().load_average_start;
    write_markdown(md_path, info, outcomes);
    const fs::path json_path = data_dir / (md_path.stem().string() + ".json");
    write_json(json_path, info, outcomes, md_path);
    std::printf("wrote %s and %s (%.1f s)\n", md_path.c_str(), json_path.c_str(),
                info.total_seconds);
    return failures == 0 ? 0 : 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "accuracy_report: error: %s\n", e.what());
    return 1;
  }
}
