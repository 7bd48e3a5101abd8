// The export report as JSON (`tsf export --stats`) and as summary lines.
#include <cstdio>

#include "tsf/export/mesh_export.h"

namespace tsf::exporter {

namespace {

nlohmann::json defects_json(const TriangleDefects& d) {
  return {{"triangles", d.triangles}, {"zero_area", d.zero_area}, {"duplicates", d.duplicates}};
}

}  // namespace

std::string thousands(std::size_t n) {
  std::string digits = std::to_string(n), out;
  for (std::size_t i = 0; i < digits.size(); ++i) {
    if (i > 0 && (digits.size() - i) % 3 == 0) out += ',';
    out += digits[i];
  }
  return out;
}

nlohmann::json export_report_json(const ExportReport& r) {
  nlohmann::json j;
  j["format"] = format_info(r.format).name;
  j["units"] = unit_name(r.units);
  j["axes"] = axes_name(r.axes);
  j["states"] = r.states;
  j["animated"] = r.animated;
  if (!r.animation_note.empty()) j["animation_note"] = r.animation_note;
  if (r.topology_runs > 0) j["topology_runs"] = r.topology_runs;
  j["meshes_per_file"] = r.meshes_per_file;
  j["tissues"] = r.tissues;
  j["vertices"] = r.vertices;
  j["triangles"] = r.triangles;
  j["input_triangles"] = r.input_triangles;
  j["normals_without_area"] = r.normals_without_area;
  const CleanupReport& c = r.cleanup;
  j["cleanup"] = {{"before", defects_json(c.before)},
                  {"after", defects_json(c.after)},
                  {"welded_vertices", c.welded_vertices},
                  {"collapsed_removed", c.collapsed_removed},
                  {"duplicates_removed", c.duplicates_removed},
                  {"fins_removed", c.fins_removed},
                  {"caps_flipped", c.caps_flipped},
                  {"caps_removed", c.caps_removed}};
  j["written"] = defects_json(r.written);
  j["levels"] = nlohmann::json::array();
  for (const LevelReport& l : r.levels) {
    nlohmann::json level = {
        {"vertices", l.vertices}, {"triangles", l.triangles}, {"decimated", l.decimated}};
    if (l.decimated) {
      level["decimate_s"] = l.decimate_s;
      level["decimate_critical_path_cpu_s"] = l.decimate_idle_s;
      level["meshopt_error_mm"] = l.meshopt_error_mm;
      level["slabs"] = l.slabs;
      level["meshopt_runs"] = l.rounds;
      level["locked_vertices"] = l.locked_vertices;
      level["nonmanifold_vertices_left"] = l.nonmanifold_vertices;
      level["repaired_triangles"] = l.repaired_triangles;
    }
    if (l.deviation) {
      const SurfaceDeviation& d = *l.deviation;
      level["distance_to_full_mm"] = {{"two_sided_mean", d.mean_mm()},
                                      {"two_sided_max", d.max_mm()},
                                      {"full_to_level_mean", d.from_full_mean_mm},
                                      {"full_to_level_max", d.from_full_max_mm},
                                      {"level_to_full_mean", d.to_full_mean_mm},
                                      {"level_to_full_max", d.to_full_max_mm},
                                      {"samples", d.from_full_samples + d.to_full_samples},
                                      {"seconds", d.seconds}};
    }
    j["levels"].push_back(level);
  }
  for (const auto& b : r.bodies)
    j["bodies"].push_back({{"tissue", b.tissue},
                           {"vertices", b.vertices},
                           {"triangles", b.triangles},
                           {"components", b.components},
                           {"closed_manifold", b.closed_manifold},
                           {"boundary_edges", b.boundary_edges},
                           {"nonmanifold_edges", b.nonmanifold_edges},
                           {"nonmanifold_vertices", b.nonmanifold_vertices}});
  for (const auto& f : r.files)
    j["files"].push_back({{"path", f.path.string()}, {"bytes", f.bytes}, {"content", f.content}});
  j["times_s"] = {{"prepare", r.prepare_s}, {"clean", r.clean_s}, {"decimate", r.decimate_s},
                  {"measure", r.measure_s}, {"scene", r.scene_s}, {"assimp", r.assimp_s},
                  {"finish", r.finish_s},   {"write", r.write_s}};
  return j;
}

std::vector<std::string> export_summary_lines(const ExportReport& r) {
  std::vector<std::string> lines;
  const CleanupReport& c = r.cleanup;
  char buf[512];
  std::snprintf(buf, sizeof(buf),
                "triangles: %s in (%s zero-area, %s duplicates) -> %s clean (%s vertices welded, "
                "%s collapsed + %s duplicate + %s fin triangles dropped, %s caps flipped, %s "
                "dropped)",
                thousands(c.before.triangles).c_str(), thousands(c.before.zero_area).c_str(),
                thousands(c.before.duplicates).c_str(), thousands(c.after.triangles).c_str(),
                thousands(c.welded_vertices).c_str(), thousands(c.collapsed_removed).c_str(),
                thousands(c.duplicates_removed).c_str(), thousands(c.fins_removed).c_str(),
                thousands(c.caps_flipped).c_str(), thousands(c.caps_removed).c_str());
  lines.push_back(buf);
  for (std::size_t k = 0; k < r.levels.size(); ++k) {
    const LevelReport& l = r.levels[k];
    if (!l.decimated) continue;
    std::string s =
        (r.levels.size() > 1 ? "level " + std::to_string(k) : std::string("decimated")) + ": " +
        thousands(l.triangles) + " triangles";
    std::snprintf(buf, sizeof(buf), " in %.2f s", l.decimate_s);
    s += buf;
    if (l.deviation) {
      const SurfaceDeviation& d = *l.deviation;
      std::snprintf(buf, sizeof(buf),
                    "; distance to the full surface mean %.3f mm, max %.3f mm (two-sided; full "
                    "to level %.3f / %.3f, level to full %.3f / %.3f)",
                    d.mean_mm(), d.max_mm(), d.from_full_mean_mm, d.from_full_max_mm,
                    d.to_full_mean_mm, d.to_full_max_mm);
      s += buf;
    }
    lines.push_back(s);
  }
  std::snprintf(buf, sizeof(buf), "written: %s triangles, %s zero-area, %s duplicates",
                thousands(r.written.triangles).c_str(), thousands(r.written.zero_area).c_str(),
                thousands(r.written.duplicates).c_str());
  lines.push_back(buf);
  for (const auto& b : r.bodies)
    lines.push_back("body " + b.tissue + ": " + thousands(b.triangles) + " triangles in " +
                    thousands(b.components) + " pieces, " +
                    (b.closed_manifold
                         ? std::string("closed manifold")
                         : "NOT a closed manifold (" + thousands(b.boundary_edges) +
                               " open edges, " + thousands(b.nonmanifold_edges) +
                               " edges of more than two triangles, " +
                               thousands(b.nonmanifold_vertices) + " pinched vertices)"));
  return lines;
}

}  // namespace tsf::exporter
