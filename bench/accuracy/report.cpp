// Markdown, plots and JSON of the accuracy-vs-time report (report.h).
#include "report.h"

#include <omp.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <fstream>
#include <iostream>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>
#include <thread>

#include "tsf/common/atomic_file.h"
#include "tsf/common/error.h"

namespace tsf::accuracy {
namespace fs = std::filesystem;
namespace {

std::string first_line_of(const fs::path& file, const std::string& prefix) {
  std::ifstream in(file);
  std::string line;
  while (std::getline(in, line))
    if (prefix.empty() || line.rfind(prefix, 0) == 0) return line;
  return "";
}

std::string gnuplot_quote(const std::string& text) {
  std::string out = "\"";
  for (char c : text) {
    if (c == '"' || c == '\\') out += '\\';
    out += c;
  }
  return out + "\"";
}

std::string markdown_cell(const std::string& text) {
  std::string out;
  for (char c : text) out += c == '|' ? std::string("\\|") : std::string(1, c);
  return out;
}

void append_table(std::ostringstream& md, const StudyTable& table) {
  if (!table.caption.empty()) md << table.caption << "\n\n";
  md << "|";
  for (const auto& c : table.columns) md << " " << markdown_cell(c) << " |";
  md << "\n|";
  for (std::size_t i = 0; i < table.columns.size(); ++i) md << (i == 0 ? " --- |" : " ---: |");
  md << "\n";
  for (const auto& row : table.rows) {
    md << "|";
    for (const auto& c : row.cells) md << " " << markdown_cell(c) << " |";
    md << "\n";
  }
  md << "\n";
}

std::string anchor_of(const KnobStudy& s) {
  std::string a;
  for (char c : s.title) {
    if (std::isalnum(static_cast<unsigned char>(c))) {
      a += static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    } else if (c == ' ' || c == '-') {
      a += '-';
    }
  }
  return a;
}

}  // namespace

RunInfo collect_run_info() {
  RunInfo info;
  const std::time_t now = std::time(nullptr);
  char date[64];
  std::strftime(date, sizeof date, "%Y-%m-%d %H:%M UTC", std::gmtime(&now));
  info.date_utc = date;
  std::string cpu = first_line_of("/proc/cpuinfo", "model name");
  const auto colon = cpu.find(':');
  info.cpu = colon == std::string::npos ? "unknown CPU" : cpu.substr(colon + 2);
  info.logical_cores = static_cast<int>(std::thread::hardware_concurrency());
  info.threads = omp_get_max_threads();
  info.load_average_start = first_line_of("/proc/loadavg", "");
#if defined(__clang__)
  info.compiler = "clang " __clang_version__;
#elif defined(__GNUC__)
  info.compiler = "gcc " __VERSION__;
#else
  info.compiler = "unknown compiler";
#endif
  return info;
}

bool write_plot(const KnobStudy& study, const StudyResult& result, const fs::path& data_dir,
                const fs::path& png) {
  const PlotSpec& plot = result.plot;
  if (plot.series.empty()) return false;
  std::ostringstream gp;
  gp << "# accuracy-vs-time plot of study '" << study.id
     << "' (written by bench/accuracy; render with gnuplot)\n"
     << "set terminal pngcairo size 860,520 font 'DejaVu Sans,10'\n"
     << "set output " << gnuplot_quote(png.string()) << "\n"
     << "set title " << gnuplot_quote(study.title) << "\n"
     << "set xlabel " << gnuplot_quote(plot.x_label) << "\n"
     << "set ylabel " << gnuplot_quote(plot.y_label) << "\n"
     << "set grid\nset key outside right top\n";
  if (plot.log_x) gp << "set logscale x\nset format x '%g'\n";
  if (plot.log_y) gp << "set logscale y\nset format y '%g'\n";
  std::ostringstream dat;
  std::vector<std::string> parts;
  for (std::size_t s = 0; s < plot.series.size(); ++s) {
    const PlotSeries& series = plot.series[s];
    const std::string block = "$series" + std::to_string(s);
    gp << block << " << EOD\n";
    dat << "# series " << s << ": " << series.name << "\n";
    int points = 0;
    for (const PlotPoint& p : series.points) {
      if (!std::isfinite(p.x) || !std::isfinite(p.y)) continue;
      if ((plot.log_x && p.x <= 0) || (plot.log_y && p.y <= 0)) continue;  // not on a log axis
      char line[256];
      std::snprintf(line, sizeof line, "%.9g %.9g ", p.x, p.y);
      gp << line << gnuplot_quote(p.label) << "\n";
      dat << line << gnuplot_quote(p.label) << "\n";
      ++points;
    }
    gp << "EOD\n";
    dat << "\n\n";
    if (points == 0) continue;
    const int type = static_cast<int>(s % 8) + 1;
    parts.push_back(block + " using 1:2 with " + (series.lines ? "linespoints" : "points") +
                    " lw 2 pt " + std::to_string(type == 3 ? 9 : type + 4) + " ps 1.3 title " +
                    gnuplot_quote(series.name));
    parts.push_back(block + " using 1:2:3 with labels offset char 0.6,0.7 font ',8' notitle");
  }
  if (parts.empty()) return false;
  gp << "plot ";
  for (std::size_t i = 0; i < parts.size(); ++i) gp << (i ? ", \\\n     " : "") << parts[i];
  gp << "\n";
  const fs::path script = data_dir / ("accuracy-" + study.id + ".gp");
  write_text_atomically(script, gp.str());
  write_text_atomically(data_dir / ("accuracy-" + study.id + ".dat"), dat.str());
  fs::create_directories(png.parent_path());
  const fs::path log = data_dir / ("accuracy-" + study.id + ".gnuplot.log");
  const std::string command =
      "gnuplot " + gnuplot_quote(script.string()) + " > " + gnuplot_quote(log.string()) + " 2>&1";
  const int rc = std::system(command.c_str());
  if (rc != 0 || !fs::exists(png) || fs::file_size(png) == 0) {
    std::cerr << "accuracy_report: gnuplot failed for " << study.id << " (exit " << rc << "); see "
              << log << "\n";
    return false;
  }
  return true;
}

void write_markdown(const fs::path& path, const RunInfo& info,
                    const std::vector<StudyOutcome>& outcomes) {
  std::ostringstream md;
  md << "# Accuracy vs time\n\n"
     << "What each accuracy knob of tsf costs in time: for every knob, the error against a "
        "reference and the time, measured in the same run. **Generated** by "
        "`scripts/accuracy-report.sh` (the `accuracy_report` app in `bench/accuracy/`); do not "
        "edit by hand — change the study and re-run.\n\n";
  md << "| run | |\n| --- | --- |\n"
     << "| date | " << info.date_utc << " |\n"
     << "| commit | " << (info.commit.empty() ? "(not given)" : info.commit) << " |\n"
     << "| mode | " << (info.quick ? "quick (CI-sized problems)" : "full") << " |\n"
     << "| machine | " << info.cpu << ", " << info.logical_cores << " logical cores |\n"
     << "| threads | " << info.threads << " OpenMP threads |\n"
     << "| load average (1/5/15 min, start → end) | " << info.load_average_start << " → "
     << info.load_average_end << " |\n"
     << "| compiler | " << info.compiler << " |\n"
     << "| timing | median of " << info.repeats << " repeats (single long runs: one) |\n"
     << "| total run time | " << format_seconds(info.total_seconds) << " |\n"
     << "| command | `" << info.command << "` |\n\n"
     << "Times come from a development machine shared with other engineers' builds: ratios "
        "within one table are meaningful, absolute values are noisy (the load average above "
        "says how busy it was).\n\n";

  md << "## Key rows\n\n| study | setting | error | time |\n| --- | --- | ---: | ---: |\n";
  for (const auto& o : outcomes)
    for (const auto& k : o.result.key_rows)
      md << "| [" << markdown_cell(o.study.title) << "](#" << anchor_of(o.study) << ") | "
         << markdown_cell(k.setting) << " | " << markdown_cell(k.error) << " | "
         << markdown_cell(k.time) << " |\n";
  md << "\n## Studies\n\n";
  for (const auto& o : outcomes)
    md << "- [" << o.study.title << "](#" << anchor_of(o.study) << ")\n";
  md << "- [Not in this report: CRMS effects, the lattice haptic model]"
        "(#not-in-this-report-crms-effects-the-lattice-haptic-model)\n"
     << "- [Adding a knob study](#adding-a-knob-study)\n\n";

  md << "## Conventions\n\n"
     << "* **Same body.** The lattice and the FEM reference are built on the same cells: a "
        "lattice node owns the cell centred on it, the FEM has one trilinear hexahedron per "
        "cell (`tissue/include/tsf/reference/`), so both describe the same voxel body. Anchored "
        "cells are a rigid layer behind the wall (lattice: anchored nodes; FEM: every corner of "
        "an anchored cell).\n"
        "* **Compared quantities.** Tip deflection: lattice = mean of the free-end node layer, "
        "FEM = centre of the end face, beam theory = qL⁴/8EI at the free end. Loaded surface: "
        "lattice = mean of the loaded node layer, FEM = field on the loaded face under those "
        "nodes. *Field* errors compare the lattice node displacement with the FEM field at the "
        "node's rest position (RMS, relative to the RMS FEM displacement).\n"
        "* **FEM reference.** Incompatible-mode hexahedra (Taylor–Wilson, no shear or volumetric "
        "locking up to ν = 0.49: the [Poisson ratio study](#poisson-ratio-the-volumetric-term) "
        "checks it against the B-bar element and a refined mesh there), Eigen sparse LDLT; the "
        "[first study](#"
     << (outcomes.empty() ? std::string() : anchor_of(outcomes.front().study))
     << ") shows its own convergence against beam theory.\n"
        "* **Dynamic reference.** Where a knob changes the dynamics (time step, integrator, "
        "angular form, reactions), the error is the RMS node-position difference after a fixed "
        "simulated time against a reference trajectory, relative to the reference's RMS "
        "displacement.\n"
        "* **Times** are wall times of this run (median of repeats), on the CPU backend with the "
        "thread count above.\n\n";

  for (const auto& o : outcomes) {
    md << "## " << o.study.title << "\n\n"
       << "*Knob:* " << o.study.knob << ". *Reference:* " << o.study.reference << ". *Time:* "
       << o.study.time_measure << ". (Study `" << o.study.id << "`, " << format_seconds(o.seconds)
       << " in this run.)\n\n";
    if (!o.failure.empty()) {
      md << "**This study failed in this run:** " << o.failure << "\n\n";
      continue;
    }
    for (const auto& t : o.result.tables) append_table(md, t);
    if (!o.plot_png.empty()) {
      const fs::path rel = fs::relative(o.plot_png, path.parent_path());
      md << "![" << o.study.title << "](" << rel.generic_string() << ")\n\n";
    }
    if (!o.result.findings.empty()) md << o.result.findings << "\n\n";
    if (!o.result.checks.empty()) {
      md << "*Checked in this run* (`accuracy_report --verify` fails otherwise):\n\n";
      for (const auto& c : o.result.checks)
        md << "- " << (c.passed ? "✓ " : "✗ **FAILED** ") << c.claim << " (" << c.detail << ")\n";
      md << "\n";
    }
  }

  md << "## Adding a knob study\n\n"
     << "1. Create `bench/accuracy/study_<name>.cpp` (the build globs `study_*.cpp`). Write a "
        "function `StudyResult run(const RunOptions&)` that builds the scene for each setting of "
        "the knob, measures the error against a reference (an analytic solution, the FEM "
        "reference in `tsf/reference/fem_hex.h`, an analytic surface, or a converged run of the "
        "product itself) and the time **in the same run** (`median_seconds()` in `scenes.h`), and "
        "fills one or more `StudyTable`s, a `PlotSpec` (error against time by default, one "
        "series per variant, points labelled with the knob value), a findings paragraph "
        "computed from the numbers, one to three `key_rows` for the table at the top, and "
        "`checks`: properties the numbers must have (the finest setting beats the coarsest, …) "
        "that `--verify` and the `AccuracyReport.*` ctests enforce.\n"
        "2. Register it: `TSF_REGISTER_KNOB_STUDY(kMyStudy, {\"my-id\", \"Title\", \"what is "
        "varied\", \"what the error is against\", \"what the time measures\", order, run});` "
        "(`knob_study.h`). The order places the section; the id names the plot "
        "`docs/images/accuracy-<id>.png`.\n"
        "3. Honour `RunOptions::quick` (CI runs `AccuracyReport.*` in quick mode: the whole "
        "report must stay within about a minute there) and keep the full run of all studies "
        "under ~10 minutes on 2 cores.\n"
        "4. Run `scripts/accuracy-report.sh` and commit the regenerated markdown and PNGs. "
        "`accuracy_report --only my-id --quick --markdown /tmp/r.md` runs one study alone.\n\n"
        "\n";
  md << "## Not in this report: CRMS effects, the lattice haptic model\n\n"
     << "* **Each CRMS effect** (plasticity, anisotropy, fluid dispersion, tearing) has no "
        "accuracy knob of its own "
        "here: what it costs per step, and that a disabled effect costs nothing, is measured by "
        "`bench_effects` (bench/tissue/) and documented in [docs/effects.md](effects.md). The "
        "volumetric term (a material's Poisson ratio) is the exception: its accuracy and time are "
        "the [Poisson ratio study](#poisson-ratio-the-volumetric-term).\n"
        "* **The lattice haptic model** reads the reactions the simulation's contact pass sums "
        "(no intersection volume, O(1) per evaluation), so the force-law reference of the "
        "[haptic model study](#haptics-force-model-and-resolution) does not apply to it; its "
        "accuracy is the lattice's (the CRMS studies above) and its cost is the contact pass's "
        "(docs/haptics.md).\n\n";
  md << "## Reproducing\n\n```\nscripts/accuracy-report.sh            # full report (~10 min "
        "on 2 cores)\nscripts/accuracy-report.sh --quick    # CI-sized check, writes to "
        "build/accuracy-quick/\n```\n";
  write_text_atomically(path, md.str());
}

void write_json(const fs::path& path, const RunInfo& info,
                const std::vector<StudyOutcome>& outcomes, const fs::path& markdown) {
  nlohmann::json j;
  j["run"] = {{"date_utc", info.date_utc},
              {"commit", info.commit},
              {"cpu", info.cpu},
              {"logical_cores", info.logical_cores},
              {"threads", info.threads},
              {"load_average_start", info.load_average_start},
              {"load_average_end", info.load_average_end},
              {"compiler", info.compiler},
              {"quick", info.quick},
              {"plots", info.plots},
              {"repeats", info.repeats},
              {"total_seconds", info.total_seconds},
              {"command", info.command},
              {"only", info.only}};
  j["markdown"] = fs::absolute(markdown).string();
  nlohmann::json studies = nlohmann::json::array();
  for (const auto& o : outcomes) {
    nlohmann::json s;
    s["id"] = o.study.id;
    s["title"] = o.study.title;
    s["knob"] = o.study.knob;
    s["reference"] = o.study.reference;
    s["seconds"] = o.seconds;
    s["failure"] = o.failure;
    s["plot"] = o.plot_png.empty() ? "" : fs::absolute(o.plot_png).string();
    nlohmann::json tables = nlohmann::json::array();
    for (const auto& t : o.result.tables) {
      nlohmann::json jt;
      jt["caption"] = t.caption;
      jt["columns"] = t.columns;
      nlohmann::json rows = nlohmann::json::array();
      for (const auto& r : t.rows) {
        nlohmann::json jr;
        jr["cells"] = r.cells;
        nlohmann::json errors = nlohmann::json::object(), times = nlohmann::json::object();
        // Non-finite numbers have no JSON form: written as null, which --verify reports.
        for (const auto& [name, value] : r.errors)
          errors[name] = std::isfinite(value) ? nlohmann::json(value) : nlohmann::json(nullptr);
        for (const auto& [name, value] : r.times_s)
          times[name] = std::isfinite(value) ? nlohmann::json(value) : nlohmann::json(nullptr);
        jr["errors"] = errors;
        jr["times_s"] = times;
        rows.push_back(jr);
      }
      jt["rows"] = rows;
      tables.push_back(jt);
    }
    s["tables"] = tables;
    nlohmann::json checks = nlohmann::json::array();
    for (const auto& c : o.result.checks)
      checks.push_back({{"claim", c.claim}, {"passed", c.passed}, {"detail", c.detail}});
    s["checks"] = checks;
    studies.push_back(s);
  }
  j["studies"] = studies;
  write_text_atomically(path, j.dump(2) + "\n");
}

int verify_report(const fs::path& json_path, const std::vector<std::string>& registered) {
  int problems = 0;
  auto problem = [&](const std::string& what) {
    std::cerr << "accuracy_report --verify: " << what << "\n";
    ++problems;
  };
  std::ifstream in(json_path);
  if (!in) {
    problem("cannot read " + json_path.string());
    return problems;
  }
  nlohmann::json j;
  try {
    in >> j;
  } catch (const nlohmann::json::exception& e) {
    problem(json_path.string() + " is not valid JSON: " + e.what());
    return problems;
  }
  auto non_empty_file = [](const std::string& p) {
    std::error_code ec;
    return !p.empty() && fs::exists(p, ec) && fs::file_size(p, ec) > 0;
  };
  if (!j.contains("markdown") || !non_empty_file(j["markdown"].get<std::string>()))
    problem("the markdown report is missing or empty");
  if (!j.contains("studies") || !j["studies"].is_array() || j["studies"].empty()) {
    problem("no studies in " + json_path.string());
    return problems;
  }
  std::set<std::string> ids;
  for (const auto& s : j["studies"]) {
    const std::string id = s.value("id", std::string("?"));
    if (!ids.insert(id).second) problem("study '" + id + "' appears twice");
    if (!s.value("failure", std::string()).empty())
      problem("study '" + id + "' failed: " + s["failure"].get<std::string>());
    if (j["run"].value("plots", true) && !non_empty_file(s.value("plot", std::string())))
      problem("study '" + id + "' has no plot file");
    int rows = 0;
    for (const auto& t : s["tables"])
      for (const auto& r : t["rows"]) {
        ++rows;
        if (r["errors"].empty() && r["times_s"].empty())
          problem("study '" + id + "': a row carries neither an error nor a time");
        for (const auto& [name, value] : r["errors"].items())
          if (!value.is_number() || !std::isfinite(value.get<double>()))
            problem("study '" + id + "': error '" + name + "' is not finite");
        for (const auto& [name, value] : r["times_s"].items())
          if (!value.is_number() || !(value.get<double>() > 0.0))
            problem("study '" + id + "': time '" + name + "' is not a positive number");
      }
    if (rows == 0) problem("study '" + id + "' has no rows");
    if (s.contains("checks"))
      for (const auto& c : s["checks"])
        if (!c.value("passed", false))
          problem("study '" + id + "': check failed: " + c.value("claim", std::string("?")) + " (" +
                  c.value("detail", std::string()) + ")");
  }
  const bool selected = j["run"].contains("only") && !j["run"]["only"].empty();
  if (!selected)
    for (const auto& id : registered)
      if (!ids.count(id)) problem("study '" + id + "' is registered but missing from the report");
  return problems;
}

}  // namespace tsf::accuracy
