// Markdown and PNG plots of a `tsf run` (run_report.h).
#include "run/run_report.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "tsf/common/atomic_file.h"

namespace tsf::app {
namespace fs = std::filesystem;
using nlohmann::json;

namespace {

std::string quote(const std::string& text) {
  std::string out = "\"";
  for (char c : text) {
    if (c == '"' || c == '\\') out += '\\';
    out += c;
  }
  return out + "\"";
}

std::string count(double v);

/// `significant` digits, never in e-notation for the magnitudes a report shows: 1,540 rather than
/// 1.54e+03.
std::string number(double v, int significant = 3) {
  if (std::fabs(v) >= 1e3 && std::fabs(v) < 1e15) {
    const double scale = std::pow(10.0, std::floor(std::log10(std::fabs(v))) - significant + 1);
    return count(std::round(v / scale) * scale);
  }
  char b[64];
  std::snprintf(b, sizeof b, "%.*g", significant, v);
  return b;
}

std::string seconds(double s) {
  if (s < 1e-3) return number(s * 1e6) + " µs";
  if (s < 1.0) return number(s * 1e3) + " ms";
  return number(s) + " s";
}

/// µN in the unit a person reads: µN, mN or N.
std::string force(double un) {
  const double a = std::fabs(un);
  if (a < 1e3) return number(un) + " µN";
  if (a < 1e6) return number(un * 1e-3) + " mN";
  return number(un * 1e-6) + " N";
}

/// An integer with thousands separators (12 868).
std::string count(double v) {
  std::string digits = std::to_string(static_cast<long long>(std::llround(v)));
  std::string out;
  const bool negative = !digits.empty() && digits[0] == '-';
  if (negative) digits.erase(0, 1);
  for (std::size_t i = 0; i < digits.size(); ++i) {
    if (i > 0 && (digits.size() - i) % 3 == 0) out += ',';
    out += digits[i];
  }
  return (negative ? "-" : "") + out;
}

/// Renders a gnuplot script to `png`; false (and no image) when gnuplot is missing or fails. The
/// script and gnuplot's messages live in a temporary folder that is removed afterwards.
bool render(const std::string& script, const fs::path& png) {
  std::error_code ec;
  const fs::path work = fs::temp_directory_path(ec) /
                        ("tsf-plot-" + std::to_string(std::hash<std::string>{}(png.string())));
  fs::create_directories(work, ec);
  const fs::path gp = work / "plot.gp";
  write_text_atomically(gp, script);
  const std::string cmd =
      "gnuplot " + quote(gp.string()) + " > " + quote((work / "gnuplot.log").string()) + " 2>&1";
  const int rc = std::system(cmd.c_str());
  fs::remove_all(work, ec);
  return rc == 0 && fs::exists(png, ec) && fs::file_size(png, ec) > 0;
}

std::string header(const fs::path& png, const std::string& title, const std::string& xlabel,
                   const std::string& ylabel) {
  return "set terminal pngcairo size 860,480 font 'DejaVu Sans,10'\nset output " +
         quote(png.string()) + "\nset title " + quote(title) + "\nset xlabel " + quote(xlabel) +
         "\nset ylabel " + quote(ylabel) + "\nset grid\nset key outside right top\n";
}

/// Everything a section needs: the report, where its images go, its name, whether to plot.
struct ReportContext {
  const json& r;
  fs::path images;
  std::string name;
  bool plots;
  json instances;
};

std::string instance_tag(const ReportContext& c, const json& in) {
  return c.instances.size() > 1 ? "`" + in.value("name", "") + "`: " : std::string();
}

// ---- verdict: what happened, in one paragraph, and what to try ------------------------------

/// What to try next after a completed run: look at it, hand it on, make it faster.
std::string next_steps(const ReportContext& c) {
  if (c.r.value("verdict", "completed") != "completed") return "";
  std::string view = "`tsf view " + c.r["scene"].value("file", "SCENE") + "`";
  if (c.r["segmentation"].is_object())
    view = "`tsf view " +
           (fs::path(c.r.value("output_folder", "")) / (c.name + "-density.nrrd")).string() + "`";
  std::string s = "Next: look at the tissue live (" + view + "), hand the meshes on (`tsf export`";
  const json exported = c.r.value("exported", json::array());
  if (!exported.empty()) s += "; the GLB is already here";
  s += ")";
  if (c.r["rates"].value("real_time_factor", 0.0) < 1.0)
    s += "; it ran slower than real time: a coarser lattice (`lattice.node_spacing_voxels`) or "
         "the CUDA backend (`--backend cuda`) speeds it up";
  return s + ".\n\n";
}

void verdict_section(const ReportContext& c, std::ostream& md) {
  const json& r = c.r;
  const std::string verdict = r.value("verdict", "completed");
  const json& interaction = r["interaction"];
  const json& stability = r.value("stability", json::object());
  const std::string stable_word = stability.is_object() ? stability.value("verdict", "") : "";
  md << "# " << c.name << ": " << (verdict == "completed" ? "completed" : verdict)
     << (verdict == "completed" && !stable_word.empty() ? ", " + stable_word : std::string())
     << "\n\n";
  if (verdict != "unstable" && !stable_word.empty()) {
    const std::string advice = stability.value("advice", "");
    md << "**Stability: " << stable_word << ".** " << stability.value("reason", "")
       << (advice.empty() ? "" : "; try " + advice)
       << ". Signals and thresholds: docs/stability.md.\n\n";
  }
  if (verdict == "unstable") {
    std::string reason = r.value("verdict_reason", "");
    if (reason.rfind("unstable: ", 0) == 0) reason = reason.substr(10);
    md << "**Unstable.** " << reason << ".";
    if (reason.find("; try ") == std::string::npos)  // the NaN guard's message has no advice
      md << " Try a smaller time step (`solver.dt`, or a lower `solver.dt_safety`), the implicit "
            "integrator for stiff tissue (`solver.integrator: implicit-euler`), or more damping "
            "(`stability.kinetic_damping`, the material's viscosity).";
    if (r["failure"].is_null()) md << " `stability.allow_unstable: true` kept the exit status 0.";
    md << " Signals and thresholds: docs/stability.md.\n\n";
  } else if (verdict == "interrupted")
    md << "**Interrupted.** " << r.value("verdict_reason", "")
       << ". The report, meshes and states hold what was reached; run again (with `--force` into "
          "this folder) to finish.\n\n";
  double removed = 0, edits = 0;
  std::size_t closed = 0;
  for (const json& in : c.instances) {
    removed += in["totals"].value("removed_mm3", 0.0);
    edits += in["totals"].value("edits", 0.0);
    closed += in["surface"].value("closed_manifold_end", false) ? 1 : 0;
  }
  md << "Played " << seconds(r["rates"].value("simulated_s", 0.0)) << " of the script ("
     << count(interaction.value("frames", 0.0)) << " frames) on " << c.instances.size()
     << (c.instances.size() == 1 ? " tissue instance" : " tissue instances") << ": " << count(edits)
     << " edits removed " << number(removed) << " mm³ of tissue; "
     << (closed == c.instances.size() ? "every final surface is a closed manifold"
                                      : "**a final surface is not a closed manifold**")
     << ". Largest tool force " << force(interaction.value("max_tool_force_un", 0.0)) << ". Total "
     << seconds(r.value("total_seconds", 0.0)) << ".\n\n"
     << next_steps(c) << "Coordinates: " << r.value("frame", "patient (LPS), mm") << ". Scene `"
     << r["scene"].value("file", "") << "`, tsf " << r.value("tsf_version", "") << ", backend "
     << r.value("backend", "") << ". Machine-readable: `run-report.json` (same folder).\n\n";
}

// ---- warnings: what the import and the pre-segmentation checks said -------------------------

void warnings_section(const ReportContext& c, std::ostream& md) {
  const json warnings = c.r.value("warnings", json::array());
  if (warnings.empty()) return;
  md << "## Warnings\n\n";
  for (const json& w : warnings) md << "- " << w.get<std::string>() << "\n";
  md << "\n";
}

void glance_section(const ReportContext& c, std::ostream& md) {
  const json& rates = c.r["rates"];
  const json latency = c.r["interaction"].value("edit_latency_us", json::object());
  md << "| at a glance | |\n| --- | --- |\n";
  for (const json& in : c.instances) {
    const json& m = in["material"];
    md << "| tissue" << (c.instances.size() > 1 ? " `" + in.value("name", "") + "`" : "") << " | "
       << count(in.value("alive_nodes_start", 0.0)) << " lattice nodes at "
       << number(in["lattice_spacing_mm"][0].get<double>()) << " mm, "
       << (m.is_object() && m["id"].is_string() ? m["id"].get<std::string>() : "inline material")
       << " (E " << number(m.value("youngs_modulus_pa", 0.0) * 1e-3) << " kPa), "
       << in.value("integrator", "") << " at " << seconds(in.value("dt_s", 0.0)) << " |\n";
  }
  md << "| simulation | " << count(rates.value("steps", 0.0)) << " steps, "
     << number(rates.value("steps_per_s", 0.0)) << " steps/s while stepping, real-time factor "
     << number(rates.value("real_time_factor", 0.0)) << " |\n"
     << "| edit → render buffer | p50 " << seconds(latency.value("p50", 0.0) * 1e-6) << ", p99 "
     << seconds(latency.value("p99", 0.0) * 1e-6) << " |\n\n";
}

// ---- where the time went --------------------------------------------------------------------

void stages_section(const ReportContext& c, std::ostream& md) {
  md << "## Time per stage\n\n| stage | time | detail |\n| --- | ---: | --- |\n";
  std::ostringstream bars;
  int index = 0;
  for (const json& s : c.r["stages"]) {
    md << "| " << s.value("stage", "") << " | " << seconds(s.value("seconds", 0.0)) << " | "
       << s.value("detail", "") << " |\n";
    bars << index++ << " " << s.value("seconds", 0.0) << " " << quote(s.value("stage", "")) << "\n";
  }
  md << "\n";
  const json& seg = c.r["segmentation"];
  if (seg.is_object() && seg.contains("stage_times")) {
    md << "Segmentation stages: ";
    bool first = true;
    for (const json& s : seg["stage_times"]) {
      md << (first ? "" : ", ") << s.value("stage", "") << " " << seconds(s.value("seconds", 0.0));
      first = false;
    }
    md << ".\n\n";
  }
  if (!c.plots) return;
  const fs::path png = c.images / "run-stages.png";
  std::string gp = header(png, "Time per stage: " + c.name, "", "wall time (s)");
  gp +=
      "set style fill solid 0.6\nset boxwidth 0.6\nunset key\nset xtics rotate by -25\n"
      "set yrange [0:*]\n$d << EOD\n" +
      bars.str() + "EOD\nplot $d using 1:2:xtic(3) with boxes lc rgb '#4477aa'\n";
  if (render(gp, png)) md << "![time per stage](images/run-stages.png)\n\n";
}

void rates_section(const ReportContext& c, std::ostream& md) {
  const json& rates = c.r["rates"];
  md << "## Simulation rate\n\n| quantity | value |\n| --- | ---: |\n";
  if (c.instances.size() == 1)
    md << "| time step | " << seconds(c.instances[0].value("dt_s", 0.0)) << " |\n";
  else
    for (const json& in : c.instances)
      md << "| time step, `" << in.value("name", "") << "` | " << seconds(in.value("dt_s", 0.0))
         << " |\n";
  md << "| steps | " << count(rates.value("steps", 0.0)) << " |\n"
     << "| simulated time | " << seconds(rates.value("simulated_s", 0.0)) << " |\n"
     << "| steps per second (stepping only) | " << number(rates.value("steps_per_s", 0.0)) << " |\n"
     << "| node-steps per second | " << number(rates.value("node_steps_per_s", 0.0)) << " |\n"
     << "| real-time factor (simulated / wall, script) | "
     << number(rates.value("real_time_factor", 0.0)) << " |\n\n";
}

// ---- physics over time ----------------------------------------------------------------------

void energy_section(const ReportContext& c, std::ostream& md) {
  md << "## Energy over time\n\n";
  const json& energy = c.r["energy"];
  if (energy.empty()) {
    md << "No frames were simulated.\n\n";
    return;
  }
  double peak = 0;
  for (const json& e : energy) peak = std::max(peak, std::fabs(e.value("total_nj", 0.0)));
  const json& last = energy.back();
  md << "Kinetic, elastic and gravitational energy of the lattice each "
     << (energy.size() > 1 ? "recorded frame" : "frame") << ". At the end: kinetic "
     << number(last.value("kinetic_nj", 0.0)) << " nJ, elastic "
     << number(last.value("elastic_nj", 0.0)) << " nJ, total "
     << number(last.value("total_nj", 0.0)) << " nJ; largest |total| " << number(peak)
     << " nJ. Tools do work on the tissue and damping removes it, so the total is not "
        "constant.\n\n";
  if (!c.plots) return;
  std::ostringstream d;
  for (const json& e : energy)
    d << e.value("time_s", 0.0) * 1e3 << " " << e.value("kinetic_nj", 0.0) << " "
      << e.value("elastic_nj", 0.0) << " " << e.value("gravitational_nj", 0.0) << " "
      << e.value("total_nj", 0.0) << "\n";
  const fs::path png = c.images / "run-energy.png";
  const std::string gp = header(png, "Energy over time: " + c.name, "time (ms)", "energy (nJ)") +
                         "$d << EOD\n" + d.str() +
                         "EOD\nplot $d using 1:2 with lines lw 2 title 'kinetic', "
                         "$d using 1:3 with lines lw 2 title 'elastic', "
                         "$d using 1:4 with lines lw 2 title 'gravitational', "
                         "$d using 1:5 with lines lw 2 dt 2 title 'total'\n";
  if (render(gp, png)) md << "![energy over time](images/run-energy.png)\n\n";
}

void force_section(const ReportContext& c, std::ostream& md) {
  md << "## Tool force\n\n";
  const json& interaction = c.r["interaction"];
  const json contact = interaction.value("contact", json::array());
  if (contact.empty()) {
    md << "No tool touched the tissue in a pressing mode.\n\n";
    return;
  }
  md << "Force the tissue exerts on the pressing tool (the reaction of the held nodes), "
     << contact.size() << " frames; largest |F| "
     << force(interaction.value("max_tool_force_un", 0.0)) << ".\n\n";
  if (!c.plots) return;
  std::ostringstream d;
  for (const json& s : contact) {
    const auto f = s["force_un"];
    const double x = f[0], y = f[1], z = f[2];
    d << s.value("time_s", 0.0) * 1e3 << " " << x * 1e-3 << " " << y * 1e-3 << " " << z * 1e-3
      << " " << std::sqrt(x * x + y * y + z * z) * 1e-3 << "\n";
  }
  const fs::path png = c.images / "run-force.png";
  const std::string gp = header(png, "Tool force: " + c.name, "time (ms)", "force (mN)") +
                         "$d << EOD\n" + d.str() +
                         "EOD\nplot $d using 1:5 with lines lw 2 title '|F|', "
                         "$d using 1:2 with lines title 'Fx', $d using 1:3 with lines title "
                         "'Fy', $d using 1:4 with lines title 'Fz'\n";
  if (render(gp, png)) md << "![tool force](images/run-force.png)\n\n";
}

// ---- what the tools did, per instance ---------------------------------------------------------

/// "mucosa 120 of 120 mm³ reached (rate 1), cortical-bone 1.2 of 24 mm³ (0.05)" from the
/// {label: mm³} objects of what was removed and what the tools reached, largest first.
std::string by_label(const json& removed, const json& reached) {
  std::vector<std::pair<double, std::string>> v;
  for (auto it = removed.begin(); it != removed.end(); ++it)
    v.emplace_back(it.value().get<double>(), it.key());
  std::sort(v.begin(), v.end(), [](const auto& a, const auto& b) { return a.first > b.first; });
  std::string out;
  for (const auto& [mm3, label] : v) {
    const bool first = out.empty();
    out += (first ? "" : ", ") + label + " " + number(mm3);
    const double r = reached.value(label, 0.0);
    if (r > 0)
      out += " of " + number(r) + " mm³ reached (" + (first ? "effective rate " : "") +
             number(mm3 / r, 2) + ")";
    else
      out += " mm³";
  }
  return out;
}

void edits_section(const ReportContext& c, std::ostream& md) {
  md << "## Edits\n\n";
  for (const json& in : c.instances) {
    const json& totals = in["totals"];
    const json& surface = in["surface"];
    md << (c.instances.size() > 1 ? "- " + instance_tag(c, in) : std::string())
       << count(totals.value("edits", 0.0)) << " edits removed "
       << number(totals.value("removed_mm3", 0.0)) << " mm³ of tissue, deleted "
       << count(totals.value("nodes_deleted", 0.0)) << " lattice nodes and broke "
       << count(totals.value("springs_broken", 0.0)) << " springs. The final surface is "
       << (surface.value("closed_manifold_end", false) ? "a closed manifold"
                                                       : "**not** a closed manifold")
       << " (" << count(surface.value("triangles_end", 0.0)) << " triangles).";
    const json by = totals.value("removed_by_label_mm3", json::object());
    if (!by.empty()) {
      const json removal = in.value("removal", json::object());
      md << " Removed by tissue: "
         << by_label(by, totals.value("reached_by_label_mm3", json::object()))
         << " (removal rates: "
         << (removal.contains("rates_source") ? removal["rates_source"].get<std::string>()
                                              : std::string("uniform 1"))
         << (removal.value("feather_force_mn", 0.0) > 0
                 ? "; ablation × (1 − e^(−F/" + number(removal.value("feather_force_mn", 0.0)) +
                       " mN)) with F the wand's contact force"
                 : std::string())
         << ").";
    }
    if (totals.value("springs_torn", 0.0) > 0) {
      const json pieces = in.value("lattice_pieces", json::object());
      md << " Tearing tore " << count(totals.value("springs_torn", 0.0)) << " springs ("
         << count(totals.value("nodes_masked", 0.0)) << " nodes masked) and cleared "
         << number(totals.value("tear_cleared_mm3", 0.0))
         << " mm³ of voxels between the torn nodes; the lattice went from "
         << count(pieces.value("start", 0.0)) << " to " << count(pieces.value("end", 0.0))
         << (pieces.value("end", 0.0) == 1.0 ? " piece." : " pieces.");
    }
    md << "\n";
    const json exposures = in.value("exposures", json::array());
    if (!exposures.empty()) {
      md << "\n**Exposure events** (tissue removed near a watched structure):\n\n"
         << "| time | tool | structure | distance | position (LPS, mm) |\n"
         << "| ---: | --- | --- | ---: | --- |\n";
      for (const json& e : exposures) {
        const json& p = e["position_mm"];
        md << "| " << number(e.value("time_s", 0.0) * 1e3) << " ms | " << e.value("tool", "")
           << " | " << e.value("label_name", "") << " | "
           << (e.value("distance_mm", 0.0) > 0 ? number(e.value("distance_mm", 0.0)) + " mm"
                                               : std::string("reached"))
           << " | " << number(p[0].get<double>()) << ", " << number(p[1].get<double>()) << ", "
           << number(p[2].get<double>()) << " |\n";
      }
    }
  }
  md << "\n";
}

void instances_section(const ReportContext& c, std::ostream& md) {
  if (c.instances.size() <= 1) return;
  md << "## Tissue instances\n\nEvery tool acts on each instance; each has its own lattice, "
        "material, time step and outputs.\n\n"
     << "| instance | labels | spacing | alive nodes (start → end) | anchored | material | "
        "integrator, dt | steps | stepping | node-steps/s | surface end |\n"
     << "| --- | --- | ---: | ---: | ---: | --- | ---: | ---: | ---: | ---: | --- |\n";
  for (const json& in : c.instances) {
    std::string labels;
    for (const json& l : in.value("labels", json::array()))
      labels += (labels.empty() ? "" : ", ") + std::to_string(l.get<int>());
    const json& m = in["material"];
    md << "| " << in.value("name", "") << " | " << (labels.empty() ? "all" : labels) << " | "
       << number(in["lattice_spacing_mm"][0].get<double>()) << " mm | "
       << count(in.value("alive_nodes_start", 0.0)) << " → "
       << count(in.value("alive_nodes_end", 0.0)) << " | " << count(in.value("fixed_nodes", 0.0))
       << " | " << (m.is_object() && m["id"].is_string() ? m["id"].get<std::string>() : "inline")
       << " (E " << number(m.value("youngs_modulus_pa", 0.0) * 1e-3) << " kPa) | "
       << in.value("integrator", "") << ", " << seconds(in.value("dt_s", 0.0)) << " | "
       << count(in.value("steps", 0.0)) << " | " << seconds(in["timings_s"].value("stepping", 0.0))
       << " | " << number(in.value("node_steps_per_s", 0.0)) << " | "
       << count(in["surface"].value("triangles_end", 0.0)) << " triangles, "
       << (in["surface"].value("closed_manifold_end", false) ? "closed" : "**not closed**")
       << " |\n";
  }
  md << "\n";
}

// ---- effects: which ran, and (only when some did) what they cost ------------------------------

void effect_cost_table(const ReportContext& c, const json& in, std::ostream& md) {
  const json& cost = in["effect_cost"];
  md << "### Effect cost" << (c.instances.size() > 1 ? ": " + in.value("name", "") : std::string())
     << "\n\nStep time on the final lattice (" << count(cost.value("alive_nodes", 0.0))
     << " alive nodes, " << cost.value("backend", "") << "), " << cost.value("repetitions", 0)
     << " interleaved repetitions of " << cost.value("steps_per_repetition", 0)
     << " steps each; median (min – max).\n\n"
     << "| configuration | time per step | ratio to off (medians) | ratio to off (minima) | "
        "bytes per node |\n"
     << "| --- | ---: | ---: | ---: | ---: |\n";
  for (const json& k : cost["configurations"])
    md << "| " << k.value("name", "") << (k.value("unstable", false) ? " (went unstable)" : "")
       << " | " << seconds(k.value("median_us_per_step", 0.0) * 1e-6) << " ("
       << seconds(k.value("min_us_per_step", 0.0) * 1e-6) << " – "
       << seconds(k.value("max_us_per_step", 0.0) * 1e-6) << ") | "
       << number(k.value("ratio_to_off", 0.0)) << " | " << number(k.value("ratio_to_off_min", 0.0))
       << " | " << number(k.value("bytes_per_node", 0.0)) << " |\n";
  md << "\nNoise band: the two identical \"off\" configurations differ by "
     << number(100.0 * cost.value("noise_off_vs_off_again", 0.0), 2)
     << " %; the repetitions of one configuration spread by up to "
     << number(100.0 * cost.value("noise_largest_spread", 0.0), 2)
     << " % (max − min over median). A ratio inside that band is no measurable cost; a disabled "
        "effect allocates no bytes and launches no pass.\n\n";
}

void effects_section(const ReportContext& c, std::ostream& md) {
  md << "## Effects active\n\n";
  for (const json& in : c.instances) {
    std::string list;
    for (const json& e : in.value("effects_active", json::array()))
      list += (list.empty() ? "" : ", ") + e.get<std::string>();
    std::string features;
    for (const json& f : in.value("kernel_features", json::array()))
      features += (features.empty() ? "" : ", ") + f.get<std::string>();
    md << "- " << instance_tag(c, in) << (list.empty() ? "none (the base lattice only)" : list)
       << "; " << number(in.value("bytes_per_node", 0.0))
       << " bytes per node; kernel features: " << (features.empty() ? "none" : features) << "\n";
  }
  md << "\n";
  for (const json& in : c.instances)
    if (in["effect_cost"].is_object() && !in.value("effects_active", json::array()).empty())
      effect_cost_table(c, in, md);
}

void material_section(const ReportContext& c, std::ostream& md) {
  bool any = false;
  for (const json& in : c.instances) {
    const json& m = in["material"];
    if (!m.is_object() || !m["id"].is_string()) continue;
    if (!any) md << "## Material\n\n";
    any = true;
    md << instance_tag(c, in) << "`" << m.value("id", "") << "` (" << m.value("name", "")
       << ") from the material library: E = " << number(m.value("youngs_modulus_pa", 0.0) * 1e-3)
       << " kPa, damping time " << seconds(m.value("damping_time_s", 0.0)) << ", density "
       << number(m.value("density_g_per_mm3", 0.0) * 1e3) << " g/cm³. Sources:\n\n";
    for (const json& src : m["sources"]) md << "- " << src.get<std::string>() << "\n";
    md << "\n";
  }
}

// ---- the files, as they are on disk ----------------------------------------------------------

void outputs_section(const ReportContext& c, const fs::path& folder, std::ostream& md) {
  md << "## Outputs\n\nIn `" << folder.string() << "` (patient coordinates, LPS, mm):\n\n";
  auto listed = [&](const std::string& what, const json& path) {
    if (!path.is_string()) return;
    const fs::path p = path.get<std::string>();
    std::error_code ec;
    if (fs::exists(p, ec)) md << "- " << what << ": `" << p.filename().string() << "`\n";
  };
  for (const json& in : c.instances) {
    const json& outs = in["outputs"];
    const std::string tag = c.instances.size() > 1 ? "`" + in.value("name", "") + "` " : "";
    listed(tag + "rest surface (binary PLY)", outs.value("rest_mesh", json(nullptr)));
    listed(tag + "final deformed, cut surface (binary PLY)", outs.value("mesh", json(nullptr)));
    listed(tag + "saved states (.tsfmesh, for `tsf export`)", outs.value("states", json(nullptr)));
  }
  if (c.r["segmentation"].is_object())
    for (const char* suffix : {"-density.nrrd", "-labels.nrrd", "-weights.nrrd", "-report.json"})
      listed(std::string("segmentation ") + (suffix + 1),
             json((folder / (c.name + suffix)).string()));
  for (const json& e : c.r.value("exported", json::array()))
    listed("exported glTF binary (metres, y-up; docs/export.md)", e);
  if (c.r.value("exported", json::array()).empty())
    md << "- glTF/FBX/OBJ export: not in this build (TSF_WITH_ASSIMP off); `tsf export` writes "
          "them from the segmented density volume\n";
  const json& interaction_report = c.r.value("interaction_report", json(nullptr));
  md << "- this report: `run-report.md`, `run-report.json`"
     << (interaction_report.is_string()
             ? ", `" + fs::path(interaction_report.get<std::string>()).filename().string() + "`"
             : std::string())
     << " (the interaction's own report)\n";
  if (!c.plots) md << "\nPlots were switched off (pipeline.outputs.plots: false).\n";
}

}  // namespace

fs::path write_run_report(const json& r, const fs::path& folder, bool plots) {
  const fs::path images = folder / "images";
  if (plots) fs::create_directories(images);
  const ReportContext c{r, images, r["scene"].value("name", "scene"), plots,
                        r.value("instances", json::array())};
  std::ostringstream md;
  verdict_section(c, md);
  warnings_section(c, md);
  glance_section(c, md);
  stages_section(c, md);
  rates_section(c, md);
  energy_section(c, md);
  force_section(c, md);
  edits_section(c, md);
  instances_section(c, md);
  effects_section(c, md);
  material_section(c, md);
  outputs_section(c, folder, md);
  const fs::path path = folder / "run-report.md";
  write_text_atomically(path, md.str());
  return path;
}

}  // namespace tsf::app
