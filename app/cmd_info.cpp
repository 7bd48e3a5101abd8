// `tsf info CT`: what a CT is before anything is done with it. The DICOM series under a folder
// (as `tsf import --list` finds them), then for the chosen volume: dimensions, spacing, direction
// cosines, orientation code (or that none is recorded), origin, the extent of the voxel centres in
// patient coordinates (LPS, mm), the HU range and the import's warnings. `--json` prints the same
// as JSON. Nothing is written.
#include <nlohmann/json.hpp>

#include <cstdio>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "commands.h"
#include "tsf/common/error.h"
#include "tsf/common/stopwatch.h"
#include "tsf/common/text_format.h"
#include "tsf/import/ct_geometry.h"
#include "tsf/import/dicom_catalog.h"
#include "tsf/import/import_volume.h"
#include "tsf/import/volume_file_reader.h"
#ifdef TSF_HAVE_SEGMENT
#include "tsf/segment/segment_preset.h"
#include "tsf/segment/segmentation_pipeline.h"
#include "tsf/segment/sinus_anatomy.h"
#endif

namespace tsf::app {
namespace {

namespace fs = std::filesystem;
using nlohmann::ordered_json;
using namespace tsf::import;

struct InfoArguments {
  std::string path;
  std::string series;
  bool json = false;
  bool no_progress = false;
  bool anatomy = false;
  double anatomy_voxel_mm = 2.0;
};

std::string vec_text(const Vec3d& v, int decimals = 1) {
  return format_text("(%.*f, %.*f, %.*f)", decimals, v.x, decimals, v.y, decimals, v.z);
}

ordered_json v3(const Vec3d& v) {
  return ordered_json::array({v.x, v.y, v.z});
}

ordered_json box_json(const Box3& b) {
  return {{"min", v3(b.lo)}, {"max", v3(b.hi)}};
}

Vec3d axis(const std::array<double, 9>& d, int column) {
  return {d[column], d[3 + column], d[6 + column]};
}

std::string format_name(const std::string& kind) {
  if (kind == "nrrd") return "NRRD volume";
  if (kind == "metaimage") return "MetaImage volume";
  if (kind == "nifti") return "NIfTI volume";
  return kind;
}

/// A series as `tsf import --list` knows it, in brief.
ordered_json series_json(const DicomSeries& s) {
  return {{"series_instance_uid", s.series_instance_uid},
          {"series_number", s.series_number},
          {"description", s.description},
          {"modality", s.modality},
          {"images", s.image_count()},
          {"slices", s.slice_count()},
          {"usable", s.usable()},
          {"problems", s.problems}};
}

void print_series_list(const DicomCatalog& catalog, const std::string& chosen) {
  std::printf("series       %zu image series (%zu usable)\n", catalog.series.size(),
              catalog.usable_series().size());
  for (const DicomSeries& s : catalog.series) {
    const bool mark = !chosen.empty() && s.series_instance_uid == chosen;
    std::printf("  %s %s\n", mark ? "*" : "-",
                s.series_instance_uid.empty() ? "(no UID)" : s.series_instance_uid.c_str());
    std::printf("      number %s, %s, %d slice%s, modality %s, %s\n",
                s.series_number.empty() ? "(none)" : s.series_number.c_str(),
                s.description.empty() ? "no description" : ("\"" + s.description + "\"").c_str(),
                s.slice_count(), s.slice_count() == 1 ? "" : "s",
                s.modality.empty() ? "(none)" : s.modality.c_str(),
                s.usable()           ? "usable"
                : s.problems.empty() ? "not usable"
                                     : ("not one volume: " + s.problems.front()).c_str());
  }
}

/// The volume part of the report: geometry from the import's output (what tsf import, segment
/// and run get), the orientation as recorded or not.
ordered_json volume_json(const CtGeometry& g, const ImportReport& r,
                         std::string& orientation_line) {
  const Box3 lps = patient_extent(g);
  const Box3 tissue = tissue_extent(g);
  const bool identity = identity_direction(g.direction);
  const double oblique = obliquity_deg(g.direction);
  ordered_json v = {{"dims", {g.dims.x, g.dims.y, g.dims.z}},
                    {"spacing_mm", v3(g.spacing)},
                    {"direction", g.direction},
                    {"axes",
                     {{"i", v3(axis(g.direction, 0))},
                      {"j", v3(axis(g.direction, 1))},
                      {"k", v3(axis(g.direction, 2))}}}};
  if (g.orientation_recorded) {
    const std::string code = orientation_code(g.direction);
    v["orientation"] = code;
    v["orientation_recorded"] = true;
    v["obliquity_deg"] = oblique;
    auto word = [](char c) -> std::string {
      switch (c) {
        case 'L':
          return "left";
        case 'R':
          return "right";
        case 'P':
          return "posterior";
        case 'A':
          return "anterior";
        case 'S':
          return "superior";
        default:
          return "inferior";
      }
    };
    orientation_line = code + " (i → patient " + word(code[0]) + ", j → " + word(code[1]) +
                       ", k → " + word(code[2]) + ")";
    if (oblique > 0.5)
      orientation_line += format_text("; oblique, up to %.1f° off the patient axes", oblique);
  } else {
    v["orientation"] = nullptr;
    v["orientation_recorded"] = false;
    v["orientation_note"] =
        "unknown — left/right not recorded: the file has no patient frame (an NRRD without "
        "'space' / 'space directions'); the axes are taken as L, P, S and the origin as 0";
    orientation_line =
        "unknown — left/right not recorded (no 'space' / 'space directions' in the header; axes "
        "taken as L, P, S, origin 0)";
  }
  v["origin_mm"] = v3(g.origin);
  v["extent_lps_mm"] = box_json(lps);
  v["size_mm"] = v3(lps.hi - lps.lo);
  v["extent_tissue_mm"] = box_json(tissue);
  v["tissue_frame_note"] =
      identity ? "the direction is the identity: scenes' crops, anchors and tools (tissue space) "
                 "use these patient coordinates"
               : "scenes' crops, anchors and tools use tissue space: origin + index × spacing, "
                 "the direction not applied";
  v["value_range"] = {r.output.min_value, r.output.max_value};
  v["units"] = r.output.units;
  v["resampled"] = r.resampling.applied;
  v["resampling_reasons"] = r.resampling.reasons;
  return v;
}

CtGeometry geometry_of(const ImportReport& r, bool orientation_recorded) {
  CtGeometry g;
  g.kind = r.source.kind;
  g.series_instance_uid = r.series.series_instance_uid;
  g.dims = r.output.dims;
  g.spacing = r.output.spacing;
  g.origin = r.output.origin;
  g.direction = r.output.direction;
  g.orientation_recorded = orientation_recorded;
  g.resampled = r.resampling.applied;
  return g;
}

void print_volume(const ordered_json& v, const std::string& orientation_line) {
  auto vec = [](const ordered_json& a, int decimals) {
    return vec_text({a[0].get<double>(), a[1].get<double>(), a[2].get<double>()}, decimals);
  };
  const auto& d = v["dims"];
  const auto& s = v["spacing_mm"];
  std::printf("  dimensions   %d × %d × %d voxels\n", d[0].get<int>(), d[1].get<int>(),
              d[2].get<int>());
  std::printf("  spacing      %.3f × %.3f × %.3f mm\n", s[0].get<double>(), s[1].get<double>(),
              s[2].get<double>());
  std::printf("  direction    i %s  j %s  k %s\n", vec(v["axes"]["i"], 3).c_str(),
              vec(v["axes"]["j"], 3).c_str(), vec(v["axes"]["k"], 3).c_str());
  std::printf("  orientation  %s\n", orientation_line.c_str());
  std::printf("  origin       %s mm (centre of voxel 0,0,0; LPS)\n",
              vec(v["origin_mm"], 2).c_str());
  const auto& e = v["extent_lps_mm"];
  std::printf(
      "  extent       x %.1f .. %.1f, y %.1f .. %.1f, z %.1f .. %.1f mm (voxel centres, "
      "patient LPS)\n",
      e["min"][0].get<double>(), e["max"][0].get<double>(), e["min"][1].get<double>(),
      e["max"][1].get<double>(), e["min"][2].get<double>(), e["max"][2].get<double>());
  std::printf("  size         %.1f × %.1f × %.1f mm\n", v["size_mm"][0].get<double>(),
              v["size_mm"][1].get<double>(), v["size_mm"][2].get<double>());
  if (!identity_direction(v["direction"].get<std::array<double, 9>>())) {
    const auto& t = v["extent_tissue_mm"];
    std::printf(
        "  scene frame  x %.1f .. %.1f, y %.1f .. %.1f, z %.1f .. %.1f mm (tissue space: "
        "origin + index × spacing; scene crops and tools use this)\n",
        t["min"][0].get<double>(), t["max"][0].get<double>(), t["min"][1].get<double>(),
        t["max"][1].get<double>(), t["min"][2].get<double>(), t["max"][2].get<double>());
  }
  std::printf("  values       %.0f .. %.0f %s\n", v["value_range"][0].get<double>(),
              v["value_range"][1].get<double>(), v["units"].get<std::string>().c_str());
  if (v["resampled"].get<bool>()) {
    std::string reasons;
    for (const auto& x : v["resampling_reasons"])
      reasons += (reasons.empty() ? "" : "; ") + x.get<std::string>();
    std::printf("  resampled    %s (the geometry above is the resampled grid)\n", reasons.c_str());
  }
}

// The crop the shipped sinus scenes place by anatomy (scenes/sinus.yaml): a box of this size
// (left-right, anterior-posterior, superior-inferior, mm) around the nose tip moved by kCropOffset
// (left, anterior, superior, mm).
constexpr double kCropSize[3] = {50, 56, 60};
constexpr double kCropOffset[3] = {0, -25, 5};

/// `--anatomy`: the sinus preset at a coarse voxel size, the anatomy it finds (as tsf segment's
/// report writes it) and the sinus scenes' crop placed by it, in LPS.
ordered_json anatomy_json(const ImportResult& imported, bool orientation_recorded,
                          const InfoArguments& a) {
#ifdef TSF_HAVE_SEGMENT
  Stopwatch clock;
  segment::SegmentPreset preset = segment::load_segment_preset("sinus");
  preset.resample.voxel_mm = a.anatomy_voxel_mm;
  segment::SegmentationOptions so;
  so.show_progress = !a.no_progress && !a.json;
  so.compute_weights = false;  // the anatomy needs the labels and air spaces only
  const segment::SegmentationResult seg = segment::segment_hu_image(imported.image, preset, so);
  segment::SinusAnatomyOptions ao;
  ao.orientation_recorded = orientation_recorded;
  const segment::SinusAnatomy anatomy = segment::find_sinus_anatomy(seg.images, ao);
  ordered_json j = segment::sinus_anatomy_json(anatomy);
  j["voxel_mm"] = a.anatomy_voxel_mm;
  j["seconds"] = clock.seconds();
  const segment::AnatomyLandmark* tip = anatomy.landmark("nose-tip");
  if (tip && tip->found) {
    const segment::AnatomyFrame& f = anatomy.frame;
    const Vec3d centre = tip->position_mm + f.left * kCropOffset[0] + f.anterior * kCropOffset[1] +
                         f.superior * kCropOffset[2];
    Vec3d lo{1e300, 1e300, 1e300}, hi{-1e300, -1e300, -1e300};
    for (int corner = 0; corner < 8; ++corner) {
      const Vec3d c = centre + f.left * (((corner & 1) ? 0.5 : -0.5) * kCropSize[0]) +
                      f.anterior * (((corner & 2) ? 0.5 : -0.5) * kCropSize[1]) +
                      f.superior * (((corner & 4) ? 0.5 : -0.5) * kCropSize[2]);
      for (int ax = 0; ax < 3; ++ax) {
        lo[ax] = std::min(lo[ax], c[ax]);
        hi[ax] = std::max(hi[ax], c[ax]);
      }
    }
    j["suggested_crop"] = {
        {"scene",
         "crop: {center: {landmark: nose-tip, offset_mm: {posterior: 25, superior: 5}}, "
         "size_mm: [50, 56, 60]}"},
        {"min_mm", {lo.x, lo.y, lo.z}},
        {"max_mm", {hi.x, hi.y, hi.z}},
        {"confidence", tip->confidence}};
  } else {
    j["suggested_crop"] = nullptr;
  }
  return j;
#else
  (void)imported, (void)orientation_recorded, (void)a;
  throw Error("--anatomy needs a build with the segment module (reconfigure with ITK)");
#endif
}

void print_anatomy(const ordered_json& j) {
  std::printf("anatomy      sinus preset at %.1f mm voxels (%.1f s), patient LPS mm%s\n",
              j["voxel_mm"].get<double>(), j["seconds"].get<double>(),
              j["orientation_recorded"].get<bool>() ? "" : ", LEFT/RIGHT UNKNOWN");
  const ordered_json& facing = j["facing"];
  std::printf("  facing     anterior (%.2f, %.2f, %.2f), confidence %.2f: %s\n",
              facing["anterior"][0].get<double>(), facing["anterior"][1].get<double>(),
              facing["anterior"][2].get<double>(), facing["confidence"].get<double>(),
              facing["reason"].get<std::string>().c_str());
  auto line = [](const ordered_json& e, const std::string& where) {
    if (!e.value("found", false)) {
      std::printf("  %-16s not found: %s\n", e["name"].get<std::string>().c_str(),
                  e.value("reason", std::string()).c_str());
      return;
    }
    std::printf("  %-16s %s, confidence %.2f\n", e["name"].get<std::string>().c_str(),
                where.c_str(), e["confidence"].get<double>());
  };
  auto p3 = [](const ordered_json& v) {
    return format_text("(%.1f, %.1f, %.1f)", v[0].get<double>(), v[1].get<double>(),
                       v[2].get<double>());
  };
  for (const ordered_json& l : j["landmarks"])
    line(l, l.value("found", false) ? p3(l["position_mm"]) : "");
  for (const ordered_json& p : j["planes"])
    line(p, p.value("found", false) ? "through " + p3(p["point_mm"]) + ", normal " + p3(p["normal"])
                                    : "");
  for (const ordered_json& r : j["regions"])
    line(r, r.value("found", false) ? format_text("%.1f ml, box ", r.value("ml", 0.0)) +
                                          p3(r["bbox_mm"]["min"]) + " to " + p3(r["bbox_mm"]["max"])
                                    : "");
  for (const auto& w : j["warnings"]) std::printf("  warning: %s\n", w.get<std::string>().c_str());
  if (j["suggested_crop"].is_null()) {
    std::printf(
        "suggested    none: no nose tip, so the sinus scenes cannot be placed on this CT\n");
    return;
  }
  const ordered_json& c = j["suggested_crop"];
  std::printf("suggested    the sinus scenes' crop %s to %s (LPS)\n               %s\n",
              p3(c["min_mm"]).c_str(), p3(c["max_mm"]).c_str(),
              c["scene"].get<std::string>().c_str());
}

void run_info(const InfoArguments& a) {
  const fs::path path(a.path);
  ordered_json out = {{"path", a.path}, {"frame", "patient (LPS), mm"}};
  std::error_code ec;
  const bool volume_file = fs::is_regular_file(path, ec) && is_volume_file_path(path);
  ImportOptions options;
  options.show_progress = !a.no_progress && !a.json;
  options.series_uid = a.series;
  bool orientation_recorded = true;

  std::optional<DicomCatalog> catalog;
  if (volume_file) {
    if (!a.series.empty())
      throw Error("--series " + a.series + ": '" + a.path + "' is a volume file, not DICOM");
    const VolumeFileHeader h = inspect_volume_file(path, options.max_voxels);
    orientation_recorded = h.has_patient_orientation;
    out["format"] = h.format;
  } else {
    CatalogOptions copt;
    copt.show_progress = options.show_progress;
    catalog = catalog_dicom(path, copt);
    out["format"] = "dicom";
    out["discovered_by"] = catalog->discovered_by;
    out["files_examined"] = catalog->files_examined;
    ordered_json series = ordered_json::array();
    for (const DicomSeries& s : catalog->series) series.push_back(series_json(s));
    out["series"] = series;
    const auto usable = catalog->usable_series();
    if (a.series.empty() && usable.size() > 1) {
      // Several volumes: list them and say how to pick one; nothing is imported.
      const std::string hint = "several usable series: choose one with `tsf info " + a.path +
                               " --series UID` (and `tsf run SCENE --ct " + a.path +
                               " --series UID` or `pipeline.source.series: UID` in a scene)";
      out["chosen_series"] = nullptr;
      out["choose"] = hint;
      out["volume"] = nullptr;
      out["warnings"] = ordered_json::array();
      if (a.json) {
        std::printf("%s\n", out.dump(2).c_str());
        return;
      }
      std::printf("%s: DICOM %s, %d files examined\n", a.path.c_str(),
                  catalog->discovered_by.c_str(), catalog->files_examined);
      print_series_list(*catalog, "");
      std::printf("\n%s\n", hint.c_str());
      return;
    }
    // The same choice the import makes (an unknown UID or no usable series is an error).
    const DicomSeries& chosen = select_dicom_series(*catalog, options);
    options.series_uid = chosen.series_instance_uid;
    options.allow_non_ct = true;  // describe any modality; the units say what the values are
  }

  const ImportResult imported = import_volume(path, options);
  const ImportReport& r = imported.report;
  const CtGeometry g = geometry_of(r, orientation_recorded);
  std::string orientation_line;
  out["chosen_series"] = volume_file ? ordered_json(nullptr) : ordered_json(g.series_instance_uid);
  out["volume"] = volume_json(g, r, orientation_line);
  out["warnings"] = r.warnings;
  if (a.anatomy) out["anatomy"] = anatomy_json(imported, orientation_recorded, a);
  if (a.json) {
    std::printf("%s\n", out.dump(2).c_str());
    return;
  }
  if (volume_file) {
    std::printf("%s: %s\n", a.path.c_str(), format_name(r.source.kind).c_str());
  } else {
    std::printf("%s: DICOM %s, %d files examined\n", a.path.c_str(), catalog->discovered_by.c_str(),
                catalog->files_examined);
    print_series_list(*catalog, g.series_instance_uid);
    std::printf("volume of series %s (%s, %d images)\n", g.series_instance_uid.c_str(),
                r.series.modality.c_str(), r.source.files_used);
  }
  print_volume(out["volume"], orientation_line);
  if (r.warnings.empty()) {
    std::printf("warnings     none\n");
  } else {
    std::printf("warnings     %zu\n", r.warnings.size());
    for (const auto& w : r.warnings) std::printf("  - %s\n", w.c_str());
  }
  if (a.anatomy) print_anatomy(out["anatomy"]);
}

constexpr const char* kInfoFooter = R"(
What it prints
  For a DICOM folder, DICOMDIR or file: every image series found (UID, number, description,
  slices, modality, usable or why not), as `tsf import --list` finds them. With several usable
  series and no --series, the list and how to choose one; nothing is read further.
  For the chosen volume (as `tsf import` would produce it, after any resampling of gantry tilt
  or uneven slice spacing): dimensions, spacing (mm), direction cosines of the voxel axes, the
  orientation as a three-letter code (LPS: the axes point toward patient Left, Posterior,
  Superior) or "unknown" when the file records no patient frame (an NRRD without 'space' /
  'space directions'), the origin, the extent of the voxel centres in patient coordinates
  (LPS, mm), the value range (HU) and the import's warnings.
  Scenes place their crop, anchors and tools in these millimetres (tissue space: origin +
  index × spacing; the same as LPS when the direction is the identity, else printed as
  "scene frame"), or by the anatomy.
  --anatomy: segments with the sinus preset at --anatomy-voxel-mm (2 mm: a few seconds) and
  prints what it finds, as tsf segment's report would: which way the face points, the nose tip,
  the nostrils, the midsagittal plane, the nasal cavity and the paranasal air spaces, each in
  LPS mm with a confidence and a reason (or why it was not found), and the box the shipped sinus
  scenes crop around the nose tip on this CT. Nothing is written.

Examples
  tsf info data-samples/ct-head-cranium/cranium.nrrd
  tsf info scans/patient-17/                   # lists the series
  tsf info scans/patient-17/ --series 1.2.840.113619.2.55.3 --json
  tsf info scans/patient-17/ --anatomy          # what the sinus scenes will be placed by
See docs/patients.md.)";

}  // namespace

void add_info_command(CLI::App& app) {
  auto args = std::make_shared<InfoArguments>();
  CLI::App* sub = app.add_subcommand(
      "info",
      "Describe a CT (DICOM folder, DICOMDIR or file; NRRD, MHA, NIfTI): its series, then the "
      "chosen volume's dimensions, spacing, orientation, origin, extent in patient coordinates "
      "(LPS, mm), HU range and import warnings. Writes nothing");
  sub->footer(kInfoFooter);
  sub->add_option("CT", args->path, "DICOM folder, DICOMDIR or file; or a .nrrd/.mha/.nii volume")
      ->required()
      ->check(CLI::ExistingPath);
  sub->add_option("-s,--series", args->series,
                  "SeriesInstanceUID to describe (needed when the folder holds several usable "
                  "series)");
  sub->add_flag("--json", args->json, "Print the same as JSON");
  sub->add_flag("--anatomy", args->anatomy,
                "Also segment with the sinus preset (coarse voxels, seconds) and print the "
                "anatomy it finds, with confidences, and the sinus scenes' crop placed by it");
  sub->add_option("--anatomy-voxel-mm", args->anatomy_voxel_mm,
                  "Voxel size for --anatomy (mm; default 2)")
      ->check(CLI::Range(0.5, 4.0));
  sub->add_flag("--no-progress", args->no_progress, "No progress bars");
  sub->callback([args] { run_info(*args); });
}

}  // namespace tsf::app
