// Markdown and PNG plots of a `tsf run` (run_report.h).
#include "run/run_report.h"

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <sstream>
#include <string>

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

std::string number(double v, int significant = 3) {
  char b[64];
  std::snprintf(b, sizeof b, "%.*g", significant, v);
  return b;
}

std::string seconds(double s) {
  if (s < 1e-3) return number(s * 1e6) + " µs";
  if (s < 1.0) return number(s * 1e3) + " ms";
  return number(s) + " s";
}

/// Renders a gnuplot script to `png`; false (and no image) when gnuplot is missing or fails.
bool render(const std::string& script, const fs::path& png, const fs::path& work) {
  const fs::path gp = work / (png.stem().string() + ".gp");
  write_text_atomically(gp, script);
  const fs::path log = work / (png.stem().string() + ".gnuplot.log");
  const std::string cmd = "gnuplot " + quote(gp.string()) + " > " + quote(log.string()) + " 2>&1";
  const int rc = std::system(cmd.c_str());
  std::error_code ec;
  return rc == 0 && fs::exists(png, ec) && fs::file_size(png, ec) > 0;
}

std::string header(const fs::path& png, const std::string& title, const std::string& xlabel,
                   const std::string& ylabel) {
  return "set terminal pngcairo size 860,480 font 'DejaVu Sans,10'\nset output " +
         quote(png.string()) + "\nset title " + quote(title) + "\nset xlabel " + quote(xlabel) +
         "\nset ylabel " + quote(ylabel) + "\nset grid\nset key outside right top\n";
}

}  // namespace

fs::path write_run_report(const json& r, const fs::path& folder, bool plots) {
  const fs::path images = folder / "images";
  fs::create_directories(images);
  const std::string name = r["scene"].value("name", "scene");
  std::ostringstream md;
  md << "# tsf run: " << name << "\n\n"
     << "Scene `" << r["scene"].value("file", "") << "`, tsf " << r.value("tsf_version", "")
     << ", backend " << r.value("backend", "") << ". Total "
     << seconds(r.value("total_seconds", 0.0))
     << ". Machine-readable: `run-report.json` (same folder).\n\n";
  if (!r["failure"].is_null())
    md << "**The run stopped early:** " << r["failure"].get<std::string>() << "\n\n";

  // ---- stages ----
  md << "## Time per stage\n\n| stage | time | detail |\n| --- | ---: | --- |\n";
  std::ostringstream bars;
  int index = 0;
  for (const json& s : r["stages"]) {
    md << "| " << s.value("stage", "") << " | " << seconds(s.value("seconds", 0.0)) << " | "
       << s.value("detail", "") << " |\n";
    bars << index++ << " " << s.value("seconds", 0.0) << " " << quote(s.value("stage", "")) << "\n";
  }
  md << "\n";
  const json& seg = r["segmentation"];
  if (seg.is_object() && seg.contains("stage_times")) {
    md << "Segmentation stages: ";
    bool first = true;
    for (const json& s : seg["stage_times"]) {
      md << (first ? "" : ", ") << s.value("stage", "") << " " << seconds(s.value("seconds", 0.0));
      first = false;
    }
    md << ".\n\n";
  }
  bool have_stage_plot = false;
  if (plots) {
    const fs::path png = images / "run-stages.png";
    std::string gp = header(png, "Time per stage: " + name, "", "wall time (s)");
    gp +=
        "set style fill solid 0.6\nset boxwidth 0.6\nunset key\nset xtics rotate by -25\n"
        "set yrange [0:*]\n$d << EOD\n" +
        bars.str() + "EOD\nplot $d using 1:2:xtic(3) with boxes lc rgb '#4477aa'\n";
    have_stage_plot = render(gp, png, folder);
    if (have_stage_plot) md << "![time per stage](images/run-stages.png)\n\n";
  }

  // ---- rates ----
  const json& rates = r["rates"];
  md << "## Simulation rate\n\n| quantity | value |\n| --- | ---: |\n"
     << "| time step | " << seconds(rates.value("dt_s", 0.0)) << " |\n"
     << "| steps | " << rates.value("steps", 0.0) << " |\n"
     << "| simulated time | " << seconds(rates.value("simulated_s", 0.0)) << " |\n"
     << "| steps per second (stepping only) | " << number(rates.value("steps_per_s", 0.0)) << " |\n"
     << "| node-steps per second | " << number(rates.value("node_steps_per_s", 0.0)) << " |\n"
     << "| real-time factor (simulated / wall, script) | "
     << number(rates.value("real_time_factor", 0.0)) << " |\n\n";

  // ---- energy ----
  md << "## Energy over time\n\n";
  const json& energy = r["energy"];
  if (energy.empty()) {
    md << "No frames were simulated.\n\n";
  } else {
    double peak = 0;
    for (const json& e : energy) peak = std::max(peak, std::fabs(e.value("total_nj", 0.0)));
    const json& last = energy.back();
    md << "Kinetic, elastic and gravitational energy of the lattice each "
       << (energy.size() > 1 ? "recorded frame" : "frame") << " (nJ). At the end: kinetic "
       << number(last.value("kinetic_nj", 0.0)) << " nJ, elastic "
       << number(last.value("elastic_nj", 0.0)) << " nJ, total "
       << number(last.value("total_nj", 0.0)) << " nJ; largest |total| " << number(peak)
       << " nJ. Tools do work on the tissue and "
       << "damping removes it, so the total is not constant; it must stay finite.\n\n";
    if (plots) {
      std::ostringstream d;
      for (const json& e : energy)
        d << e.value("time_s", 0.0) * 1e3 << " " << e.value("kinetic_nj", 0.0) << " "
          << e.value("elastic_nj", 0.0) << " " << e.value("gravitational_nj", 0.0) << " "
          << e.value("total_nj", 0.0) << "\n";
      const fs::path png = images / "run-energy.png";
      const std::string gp = header(png, "Energy over time: " + name, "time (ms)", "energy (nJ)") +
                             "$d << EOD\n" + d.str() +
                             "EOD\nplot $d using 1:2 with lines lw 2 title 'kinetic', "
                             "$d using 1:3 with lines lw 2 title 'elastic', "
                             "$d using 1:4 with lines lw 2 title 'gravitational', "
                             "$d using 1:5 with lines lw 2 dt 2 title 'total'\n";
      if (render(gp, png, folder)) md << "![energy over time](images/run-energy.png)\n\n";
    }
  }

  // ---- tool force ----
  md << "## Tool force\n\n";
  const json& interaction = r["interaction"];
  const json contact = interaction.value("contact", json::array());
  if (contact.empty()) {
    md << "No tool touched the tissue in a pressing mode.\n\n";
  } else {
    md << "Force the tissue exerts on the pressing tool (µN; the reaction of the held nodes), "
       << contact.size() << " frames; largest |F| "
       << number(interaction.value("max_tool_force_un", 0.0)) << " µN.\n\n";
    if (plots) {
      std::ostringstream d;
      for (const json& c : contact) {
        const auto f = c["force_un"];
        const double x = f[0], y = f[1], z = f[2];
        d << c.value("time_s", 0.0) * 1e3 << " " << x << " " << y << " " << z << " "
          << std::sqrt(x * x + y * y + z * z) << "\n";
      }
      const fs::path png = images / "run-force.png";
      const std::string gp = header(png, "Tool force: " + name, "time (ms)", "force (µN)") +
                             "$d << EOD\n" + d.str() +
                             "EOD\nplot $d using 1:5 with lines lw 2 title '|F|', "
                             "$d using 1:2 with lines title 'Fx', $d using 1:3 with lines title "
                             "'Fy', $d using 1:4 with lines title 'Fz'\n";
      if (render(gp, png, folder)) md << "![tool force](images/run-force.png)\n\n";
    }
  }

  // ---- edits ----
  const json instances = r.value("instances", json::array());
  md << "## Edits\n\n";
  for (const json& in : instances) {
    const json& totals = in["totals"];
    const json& surface = in["surface"];
    md << (instances.size() > 1 ? "- `" + in.value("name", "") + "`: " : std::string())
       << totals.value("edits", 0) << " edits removed " << number(totals.value("removed_mm3", 0.0))
       << " mm³ of tissue, deleted " << totals.value("nodes_deleted", 0)
       << " lattice nodes and broke " << totals.value("springs_broken", 0)
       << " springs. The final surface is "
       << (surface.value("closed_manifold_end", false) ? "a closed manifold"
                                                       : "**not** a closed manifold")
       << " (" << surface.value("triangles_end", 0) << " triangles).\n";
  }
  const json latency = interaction.value("edit_latency_us", json::object());
  md << "\nEdit → render-buffer latency p50 " << number(latency.value("p50", 0.0)) << " µs, p99 "
     << number(latency.value("p99", 0.0)) << " µs.\n\n";

  // ---- tissue instances ----
  if (instances.size() > 1) {
    md << "## Tissue instances\n\nEvery tool acts on each instance; each has its own lattice, "
          "material, time step and outputs.\n\n"
       << "| instance | labels | spacing | alive nodes (start → end) | anchored | material | "
          "integrator, dt | "
          "steps | stepping | node-steps/s | surface end |\n"
       << "| --- | --- | ---: | ---: | ---: | --- | ---: | ---: | ---: | ---: | --- |\n";
    for (const json& in : instances) {
      std::string labels;
      for (const json& l : in.value("labels", json::array()))
        labels += (labels.empty() ? "" : ", ") + std::to_string(l.get<int>());
      const json& m = in["material"];
      md << "| " << in.value("name", "") << " | " << (labels.empty() ? "all" : labels) << " | "
         << number(in["lattice_spacing_mm"][0].get<double>()) << " mm | "
         << in.value("alive_nodes_start", 0) << " → " << in.value("alive_nodes_end", 0) << " | "
         << in.value("fixed_nodes", 0) << " | "
         << (m.is_object() && m["id"].is_string() ? m["id"].get<std::string>() : "inline") << " (E "
         << number(m.value("youngs_modulus_pa", 0.0)) << " Pa) | " << in.value("integrator", "")
         << ", " << seconds(in.value("dt_s", 0.0)) << " | " << in.value("steps", 0.0) << " | "
         << seconds(in["timings_s"].value("stepping", 0.0)) << " | "
         << number(in.value("node_steps_per_s", 0.0)) << " | "
         << in["surface"].value("triangles_end", 0) << " triangles, "
         << (in["surface"].value("closed_manifold_end", false) ? "closed" : "**not closed**")
         << " |\n";
    }
    md << "\n";
  }

  // ---- effects and their cost ----
  md << "## Effects active\n\n";
  for (const json& in : instances) {
    const json active = in.value("effects_active", json::array());
    std::string list;
    for (const json& e : active) list += (list.empty() ? "" : ", ") + e.get<std::string>();
    md << "- " << (instances.size() > 1 ? "`" + in.value("name", "") + "`: " : std::string())
       << (list.empty() ? "none (the base lattice only)" : list) << "; "
       << in.value("bytes_per_node", 0.0) << " bytes per node; kernel features: ";
    std::string features;
    for (const json& f : in.value("kernel_features", json::array()))
      features += (features.empty() ? "" : ", ") + f.get<std::string>();
    md << (features.empty() ? "none" : features) << "\n";
  }
  md << "\n" << r.value("effects_note", "") << ".\n\n";
  for (const json& in : instances) {
    const json& cost = in["effect_cost"];
    if (!cost.is_object()) continue;
    md << "### Effect cost" << (instances.size() > 1 ? ": " + in.value("name", "") : std::string())
       << "\n\n"
       << "Step time on the final lattice (" << cost.value("alive_nodes", 0) << " alive nodes, "
       << cost.value("backend", "") << "), " << cost.value("repetitions", 0)
       << " interleaved repetitions of " << cost.value("steps_per_repetition", 0)
       << " steps each; median (min – max).\n\n"
       << "| configuration | µs per step | ratio to off (medians) | ratio to off (minima) | bytes "
          "per node |\n"
       << "| --- | ---: | ---: | ---: | ---: |\n";
    for (const json& c : cost["configurations"])
      md << "| " << c.value("name", "") << (c.value("unstable", false) ? " (went unstable)" : "")
         << " | " << number(c.value("median_us_per_step", 0.0)) << " ("
         << number(c.value("min_us_per_step", 0.0)) << " – "
         << number(c.value("max_us_per_step", 0.0)) << ") | "
         << number(c.value("ratio_to_off", 0.0)) << " | "
         << number(c.value("ratio_to_off_min", 0.0)) << " | "
         << number(c.value("bytes_per_node", 0.0)) << " |\n";
    md << "\nNoise band: the two identical \"off\" configurations differ by "
       << number(100.0 * cost.value("noise_off_vs_off_again", 0.0), 2)
       << " %; the repetitions of one configuration spread by up to "
       << number(100.0 * cost.value("noise_largest_spread", 0.0), 2)
       << " % (max − min over median). A ratio inside that band is no measurable cost; a disabled "
          "effect allocates no bytes and launches no pass.\n\n";
  }

  bool any_material = false;
  for (const json& in : instances) {
    const json& m = in["material"];
    if (!m.is_object() || !m["id"].is_string()) continue;
    if (!any_material) md << "## Material\n\n";
    any_material = true;
    md << (instances.size() > 1 ? "`" + in.value("name", "") + "`: " : std::string()) << "`"
       << m.value("id", "") << "` (" << m.value("name", "")
       << ") from the material library: E = " << number(m.value("youngs_modulus_pa", 0.0))
       << " Pa, damping time " << seconds(m.value("damping_time_s", 0.0)) << ", density "
       << number(m.value("density_g_per_mm3", 0.0)) << " g/mm³. Sources:\n\n";
    for (const json& src : m["sources"]) md << "- " << src.get<std::string>() << "\n";
    md << "\n";
  }
  md << "## Outputs\n\n";
  for (const json& in : instances) {
    const json& outs = in["outputs"];
    for (const char* k : {"rest_mesh", "mesh"})
      if (outs.contains(k) && outs[k].is_string())
        md << "- " << (instances.size() > 1 ? "`" + in.value("name", "") + "` " : std::string())
           << (std::string(k) == "mesh" ? "final deformed, cut surface" : "rest surface") << ": `"
           << fs::path(outs[k].get<std::string>()).filename().string() << "` (binary PLY)\n";
  }
  if (r["segmentation"].is_object())
    md << "- segmented volume: `" << name << "-density.nrrd`, `" << name << "-labels.nrrd`, `"
       << name << "-weights.nrrd`, segmentation report `" << name << "-report.json`\n";
  for (const json& e : r.value("exported", json::array()))
    md << "- exported: `" << e.get<std::string>()
       << "` (glTF binary, metres, y-up; docs/export.md)\n";
  if (r.value("exported", json::array()).empty())
    md << "- glTF/FBX/OBJ export: not in this build (TSF_WITH_ASSIMP off); `tsf export` writes "
          "them "
          "from the segmented density volume\n";
  md << "- this report: `run-report.md`, `run-report.json`, `interaction.json`\n";
  if (!plots) md << "\nPlots were switched off (pipeline.outputs.plots: false).\n";
  const fs::path path = folder / "run-report.md";
  write_text_atomically(path, md.str());
  return path;
}

}  // namespace tsf::app
