#include "scene/anatomy_placement.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <vector>

#include "tsf/common/error.h"

namespace tsf::app {

namespace {

using nlohmann::json;

constexpr double kLowConfidence = 0.5;

std::string fixed(double v, int decimals) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*f", decimals, v);
  return buf;
}

Vec3d vec(const json& j) {
  return {j.at(0).get<double>(), j.at(1).get<double>(), j.at(2).get<double>()};
}

struct Found {
  bool found = false;
  Vec3d point, lo, hi;  // LPS
  bool is_region = false;
  double confidence = 0.0;
  std::string reason;
};

/// The anatomy of a segment report, in LPS, and the segmented grid's frame.
struct ReportAnatomy {
  std::map<std::string, Found> named;
  Vec3d left{1, 0, 0}, anterior{0, -1, 0}, superior{0, 0, 1};
  Vec3d origin{0, 0, 0};
  std::array<double, 9> direction{1, 0, 0, 0, 1, 0, 0, 0, 1};
  std::vector<std::string> warnings;

  /// LPS -> tissue space (origin + index × spacing: the direction not applied).
  Vec3d tissue_point(const Vec3d& p) const { return origin + tissue_direction(p - origin); }
  Vec3d tissue_direction(const Vec3d& v) const {
    Vec3d out;
    for (int c = 0; c < 3; ++c)
      out[c] = direction[0 * 3 + c] * v.x + direction[1 * 3 + c] * v.y + direction[2 * 3 + c] * v.z;
    return out;
  }
  /// (left, anterior, superior) amounts -> an LPS vector.
  Vec3d patient_offset(const Vec3d& las) const {
    return left * las.x + anterior * las.y + superior * las.z;
  }
};

ReportAnatomy read_report_anatomy(const json& report) {
  if (!report.contains("anatomy") || !report.contains("grid"))
    throw Error("the segment report has no anatomy section");
  const json& a = report.at("anatomy");
  ReportAnatomy out;
  const json& d = a.at("directions");
  out.left = vec(d.at("left"));
  out.anterior = vec(d.at("anterior"));
  out.superior = vec(d.at("superior"));
  out.origin = vec(report.at("grid").at("origin_mm"));
  const json& dir = report.at("grid").at("direction");
  for (std::size_t i = 0; i < 9; ++i) out.direction[i] = dir.at(i).get<double>();
  for (const json& l : a.at("landmarks")) {
    Found f;
    f.found = l.value("found", false);
    f.confidence = l.value("confidence", 0.0);
    f.reason = l.value("reason", std::string());
    if (f.found) f.point = vec(l.at("position_mm"));
    out.named[l.at("name").get<std::string>()] = f;
  }
  for (const json& r : a.at("regions")) {
    Found f;
    f.is_region = true;
    f.found = r.value("found", false);
    f.confidence = r.value("confidence", 0.0);
    f.reason = r.value("reason", std::string());
    if (f.found) {
      f.point = vec(r.at("centroid_mm"));
      f.lo = vec(r.at("bbox_mm").at("min"));
      f.hi = vec(r.at("bbox_mm").at("max"));
    }
    out.named[r.at("name").get<std::string>()] = f;
  }
  for (const json& p : a.at("planes")) {
    Found f;
    f.found = p.value("found", false);
    f.confidence = p.value("confidence", 0.0);
    f.reason = p.value("reason", std::string());
    if (f.found) f.point = vec(p.at("point_mm"));
    out.named[p.at("name").get<std::string>()] = f;
  }
  for (const json& w : a.value("warnings", json::array()))
    out.warnings.push_back(w.get<std::string>());
  return out;
}

}  // namespace

std::filesystem::path segment_report_beside(const std::filesystem::path& density) {
  const std::string suffix = "-density.nrrd";
  const std::string v = density.string();
  if (v.size() <= suffix.size() || v.compare(v.size() - suffix.size(), suffix.size(), suffix) != 0)
    return {};
  return v.substr(0, v.size() - suffix.size()) + "-report.json";
}

const char* const kLeftRightUnknown =
    "left/right unknown: the source CT records no patient orientation, its axes were taken as "
    "L, P, S (the model may be mirrored)";

std::string frame_warning_beside(const std::filesystem::path& density) {
  const std::filesystem::path report = segment_report_beside(density);
  if (report.empty()) return {};
  std::ifstream in(report);
  if (!in) return {};
  try {
    const auto axes = anatomy_axes(json::parse(in));
    if (axes && !axes->orientation_recorded) return kLeftRightUnknown;
  } catch (const std::exception&) {
  }
  return {};
}

std::optional<AnatomyAxes> anatomy_axes(const json& report) {
  if (!report.contains("anatomy")) return std::nullopt;
  try {
    const json& a = report.at("anatomy");
    const json& d = a.at("directions");
    AnatomyAxes out;
    out.left = vec(d.at("left"));
    out.anterior = vec(d.at("anterior"));
    out.superior = vec(d.at("superior"));
    out.orientation_recorded = a.value("orientation_recorded", false);
    out.facing_confidence = a.at("facing").value("confidence", 0.0);
    return out;
  } catch (const std::exception&) {
    return std::nullopt;
  }
}

const std::vector<std::string>& anatomy_region_names() {
  static const std::vector<std::string> names = {
      "nasal-cavity", "maxillary-left", "maxillary-right", "frontal", "sphenoid", "ethmoid"};
  return names;
}

const std::vector<std::string>& anatomy_landmark_names() {
  static const std::vector<std::string> names = [] {
    std::vector<std::string> n = {"nose-tip", "nostril-left", "nostril-right", "midsagittal"};
    for (const std::string& r : anatomy_region_names()) n.push_back(r);
    return n;
  }();
  return names;
}

bool anatomy_direction(const std::string& word, Vec3d& v) {
  if (word == "left")
    v = {1, 0, 0};
  else if (word == "right")
    v = {-1, 0, 0};
  else if (word == "anterior")
    v = {0, 1, 0};
  else if (word == "posterior")
    v = {0, -1, 0};
  else if (word == "superior")
    v = {0, 0, 1};
  else if (word == "inferior")
    v = {0, 0, -1};
  else
    return false;
  return true;
}

std::vector<std::string> place_scene_by_anatomy(Scene& scene, const json& segment_report) {
  const std::string file = scene.file.string();
  ReportAnatomy a;
  try {
    a = read_report_anatomy(segment_report);
  } catch (const std::exception& e) {
    throw Error(file + ": " + scene.anatomy_key + ": cannot place by anatomy: " + e.what());
  }
  std::vector<std::string> warnings;
  std::map<std::string, bool> warned;
  for (const std::string& w : a.warnings) warnings.push_back(w);
  auto use = [&](const std::string& name, const std::string& key) -> const Found& {
    const auto it = a.named.find(name);
    if (it == a.named.end() || !it->second.found)
      throw Error(file + ": " + key + ": '" + name + "' was not found in this CT" +
                  (it == a.named.end() ? std::string() : " (" + it->second.reason + ")") +
                  "; give this position in millimetres instead (the segment report's anatomy "
                  "section and preview show what was found; docs/patients.md)");
    if (it->second.confidence < kLowConfidence && !warned[name]) {
      warned[name] = true;
      warnings.push_back("anatomy: " + key + " uses '" + name + "', found with confidence " +
                         fixed(it->second.confidence, 2) + " (below " + fixed(kLowConfidence, 1) +
                         "): " + it->second.reason + "; check the placement in the preview");
    }
    return it->second;
  };
  auto position = [&](const AnatomyPosition& p) {
    const Found& f = use(p.landmark, p.key);
    return a.tissue_point(f.point + a.patient_offset(p.offset_mm));
  };
  // The tissue-space bounding box of the LPS points `corners`: a crop is axis-aligned in the
  // voxel grid, so a box tilted against it (an oblique CT, a turned head) grows to hold it.
  auto tissue_bounds = [&](const std::vector<Vec3d>& corners, SceneLattice& l) {
    Vec3d lo{1e300, 1e300, 1e300}, hi{-1e300, -1e300, -1e300};
    for (const Vec3d& c : corners) {
      const Vec3d t = a.tissue_point(c);
      for (int ax = 0; ax < 3; ++ax) {
        lo[ax] = std::min(lo[ax], t[ax]);
        hi[ax] = std::max(hi[ax], t[ax]);
      }
    }
    l.cropped = true;
    l.crop_min_mm = lo;
    l.crop_max_mm = hi;
  };
  for (SceneInstance& inst : scene.instances) {
    SceneLattice& l = inst.lattice;
    if (l.crop_center.given()) {
      // A box of crop_size_mm along the patient's (left, anterior, superior) directions.
      const Found& f = use(l.crop_center.landmark, l.crop_center.key);
      const Vec3d centre = f.point + a.patient_offset(l.crop_center.offset_mm);
      std::vector<Vec3d> corners;
      for (int corner = 0; corner < 8; ++corner) {
        Vec3d las;
        for (int ax = 0; ax < 3; ++ax)
          las[ax] = ((corner >> ax) & 1 ? 0.5 : -0.5) * l.crop_size_mm[ax];
        corners.push_back(centre + a.patient_offset(las));
      }
      tissue_bounds(corners, l);
      l.crop_box_centre = a.tissue_point(centre);
      bool tilted = false;
      for (int ax = 0; ax < 3; ++ax) {
        Vec3d las{0, 0, 0};
        las[ax] = 1.0;
        const Vec3d axis = a.tissue_direction(a.patient_offset(las));
        l.crop_box_axes[static_cast<std::size_t>(ax)] = axis;
        l.crop_box_half[ax] = 0.5 * l.crop_size_mm[ax];
        tilted |= std::max({std::fabs(axis.x), std::fabs(axis.y), std::fabs(axis.z)}) < 1.0 - 1e-6;
      }
      l.crop_oriented = tilted;
    }
    if (!l.crop_region.empty()) {
      const Found& f = use(l.crop_region, l.crop_key);
      Vec3d box_lo = f.lo, box_hi = f.hi;  // LPS
      for (const std::string& n : l.crop_include) {
        const std::string include_key =
            l.crop_key.substr(0, l.crop_key.size() - std::string("region").size()) + "include";
        const Found& g = use(n, include_key);
        for (int ax = 0; ax < 3; ++ax) {
          box_lo[ax] = std::min(box_lo[ax], g.point[ax]);
          box_hi[ax] = std::max(box_hi[ax], g.point[ax]);
        }
      }
      std::vector<Vec3d> corners;
      for (int corner = 0; corner < 8; ++corner) {
        Vec3d c;
        for (int ax = 0; ax < 3; ++ax)
          c[ax] =
              (corner >> ax) & 1 ? box_hi[ax] + l.crop_margin_mm : box_lo[ax] - l.crop_margin_mm;
        corners.push_back(c);
      }
      tissue_bounds(corners, l);
    }
    for (SceneAnchor& anchor : inst.anchors) {
      if (anchor.point_anatomy.given()) anchor.point_mm = position(anchor.point_anatomy);
      if (!anchor.normal_direction.empty()) {
        Vec3d las;
        anatomy_direction(anchor.normal_direction, las);
        anchor.normal = a.tissue_direction(a.patient_offset(las));
      }
    }
  }
  // A rotation about a patient direction, right-handed in the patient frame (L, P, S): in tissue
  // space it turns about that direction's image under M = [left, posterior, superior] (tissue
  // columns), by the same angle when M keeps handedness and by its negative when M mirrors (a CT
  // stored mirrored, or a facing detected against an assumed frame).
  Vec3d cols[3];
  const Vec3d lps_words[3] = {{1, 0, 0}, {0, -1, 0}, {0, 0, 1}};  // left, posterior, superior
  for (int c = 0; c < 3; ++c) cols[c] = a.tissue_direction(a.patient_offset(lps_words[c]));
  const double handedness = dot(cols[0], cross(cols[1], cols[2])) < 0 ? -1.0 : 1.0;
  auto rotation = [&](const AnatomyPosition& p, const Rotation& given) {
    if (!p.rotation_given()) return given;
    Vec3d las;
    anatomy_direction(p.rotation_axis, las);
    return Rotation::about_axis(a.tissue_direction(a.patient_offset(las)),
                                handedness * p.rotation_angle_rad);
  };
  for (SceneTrajectory& t : scene.script.trajectories)
    for (std::size_t k = 0; k < t.keyframes.size() && k < t.anatomy.size(); ++k) {
      if (t.anatomy[k].given()) t.keyframes[k].pose.position = position(t.anatomy[k]);
      t.keyframes[k].pose.orientation = rotation(t.anatomy[k], t.keyframes[k].pose.orientation);
    }
  for (SceneEvent& e : scene.script.events) {
    if (e.from_anatomy.given()) e.from.position = position(e.from_anatomy);
    if (e.to_anatomy.given()) e.to.position = position(e.to_anatomy);
    e.from.orientation = rotation(e.from_anatomy, e.from.orientation);
    e.to.orientation = rotation(e.to_anatomy, e.to.orientation);
  }
  return warnings;
}

}  // namespace tsf::app
