// `tsf import`: a CT scan (DICOM series, DICOMDIR, enhanced multi-frame, NRRD, MHA, NIfTI) ->
// one volume in Hounsfield units (.nrrd or .mha) plus a JSON sidecar saying what was done.
#include <nlohmann/json.hpp>

#include <cstdio>
#include <filesystem>
#include <map>
#include <memory>
#include <string>

#include "commands.h"
#include "output/interrupt.h"
#include "tsf/common/error.h"
#include "tsf/common/stopwatch.h"
#include "tsf/common/text_format.h"
#include "tsf/import/dicom_catalog.h"
#include "tsf/import/hu_volume_writer.h"
#include "tsf/import/import_report_json.h"
#include "tsf/import/import_volume.h"
#include "tsf/import/volume_file_reader.h"

namespace tsf::app {
namespace {

namespace fs = std::filesystem;
using namespace tsf::import;

struct ImportCommandOptions {
  std::string path;
  std::string output;
  std::string sidecar;
  bool list = false;
  bool json = false;
  bool no_progress = false;
  bool no_compress = false;
  double max_gigavoxels = 1.0;
  ImportOptions import;
};

std::string dims_text(const Int3& d) {
  return std::to_string(d.x) + " × " + std::to_string(d.y) + " × " + std::to_string(d.z);
}

std::string spacing_text(const Vec3d& s) {
  return format_text("%.3f × %.3f × %.3f mm", s.x, s.y, s.z);
}

std::string vec_text(const Vec3d& v) {
  return format_text("(%.4g, %.4g, %.4g)", v.x, v.y, v.z);
}

/// Skipped files grouped by reason: "not DICOM (2): a.txt, b.png".
std::map<std::string, std::vector<std::string>> group_skipped(const DicomCatalog& catalog) {
  std::map<std::string, std::vector<std::string>> by_reason;
  for (const auto& k : catalog.skipped)
    by_reason[k.reason].push_back(display_path(k.path, catalog.root));
  return by_reason;
}

nlohmann::ordered_json series_json(const DicomSeries& s) {
  nlohmann::ordered_json j = {{"series_instance_uid", s.series_instance_uid},
                              {"modality", s.modality},
                              {"series_number", s.series_number},
                              {"description", s.description},
                              {"images", s.image_count()},
                              {"slices", s.slice_count()},
                              {"usable", s.usable()},
                              {"problems", s.problems}};
  if (!s.files.empty()) {
    const auto& f = s.files.front();
    j["dims"] = {f.columns, f.rows, s.slice_count()};
    if (!f.frames.empty() && f.frames.front().has_pixel_spacing)
      j["pixel_spacing_mm"] = {f.frames.front().spacing_between_columns,
                               f.frames.front().spacing_between_rows};
    j["transfer_syntax"] = dicom_uid_name(f.transfer_syntax_uid);
  }
  if (s.geometry) {
    const auto& g = *s.geometry;
    nlohmann::ordered_json gaps = nlohmann::ordered_json::array();
    for (const auto& r : g.gap_runs) gaps.push_back({{"gap_mm", r.gap_mm}, {"count", r.count}});
    j["slice_gaps"] = gaps;
    j["uneven_spacing"] = g.uneven;
    j["gantry_tilt_deg"] = g.tilt_deg;
    j["gantry_tilted"] = g.tilted;
    j["needs_resampling"] = g.needs_resampling;
    j["import_dims"] = {g.grid.dims.x, g.grid.dims.y, g.grid.dims.z};
    j["import_spacing_mm"] = {g.grid.spacing.x, g.grid.spacing.y, g.grid.spacing.z};
  }
  return j;
}

void print_series(const DicomSeries& s, int index, int count) {
  std::printf("\nseries %d of %d  %s\n", index, count, s.usable() ? "usable" : "REFUSED");
  std::printf("  uid          %s\n",
              s.series_instance_uid.empty() ? "(none)" : s.series_instance_uid.c_str());
  std::printf("  modality     %s%s\n", s.modality.empty() ? "(none)" : s.modality.c_str(),
              s.modality == "CT" || s.modality.empty() ? "" : "  (not CT: needs --any-modality)");
  std::printf("  number       %s\n", s.series_number.empty() ? "(none)" : s.series_number.c_str());
  std::printf("  description  %s\n", s.description.empty() ? "(none)" : s.description.c_str());
  std::printf("  images       %d file%s, %d slice%s\n", s.image_count(),
              s.image_count() == 1 ? "" : "s", s.slice_count(), s.slice_count() == 1 ? "" : "s");
  if (!s.files.empty()) {
    const auto& f = s.files.front();
    std::printf("  dimensions   %d × %d × %d\n", f.columns, f.rows, s.slice_count());
    std::printf("  encoding     %s, %d of %d bits %s\n",
                dicom_uid_name(f.transfer_syntax_uid).c_str(), f.bits_stored, f.bits_allocated,
                f.pixel_representation ? "signed" : "unsigned");
  }
  if (s.geometry) {
    const auto& g = *s.geometry;
    std::printf("  spacing      %.3f × %.3f mm in-plane; slice gaps %s%s\n", g.spacing_x,
                g.spacing_y, describe_gap_runs(g.gap_runs).c_str(), g.uneven ? " (uneven)" : "");
    std::printf("  orientation  rows %s, columns %s\n", vec_text(g.axes.row).c_str(),
                vec_text(g.axes.column).c_str());
    const auto& f = s.files.front();
    std::printf("  tilt         %.2f° from positions%s%s\n", g.tilt_deg,
                f.has_gantry_tilt
                    ? format_text(", GantryDetectorTilt %.2f°", f.gantry_tilt_deg).c_str()
                    : "",
                g.tilted ? " (sheared stack)" : "");
    for (const auto& m : g.missing)
      std::printf("  missing      gap of %.2f mm after slice %d: about %d slice(s)\n", m.gap_mm,
                  m.after_slice + 1, m.estimated_missing);
    if (g.needs_resampling) {
      std::string reasons;
      for (const auto& r : g.resampling_reasons) reasons += (reasons.empty() ? "" : "; ") + r;
      std::printf("  import as    %s at %s after resampling (%s)\n", dims_text(g.grid.dims).c_str(),
                  spacing_text(g.grid.spacing).c_str(), reasons.c_str());
    } else {
      std::printf("  import as    %s at %s, as acquired\n", dims_text(g.grid.dims).c_str(),
                  spacing_text(g.grid.spacing).c_str());
    }
  }
  for (const auto& p : s.problems) std::printf("  problem      %s\n", p.c_str());
}

void list_volume_file(const ImportCommandOptions& o) {
  const VolumeFileHeader h = inspect_volume_file(o.path, o.import.max_voxels);
  if (o.json) {
    nlohmann::ordered_json j = {{"path", o.path},
                                {"format", h.format},
                                {"component_type", h.component_type},
                                {"dims", {h.dims.x, h.dims.y, h.dims.z}},
                                {"spacing_mm", {h.spacing.x, h.spacing.y, h.spacing.z}},
                                {"origin_mm", {h.origin.x, h.origin.y, h.origin.z}},
                                {"direction", h.direction},
                                {"compressed", h.compressed},
                                {"patient_orientation_recorded", h.has_patient_orientation}};
    std::printf("%s\n", j.dump(2).c_str());
    return;
  }
  std::printf("%s: %s volume\n", o.path.c_str(), h.format.c_str());
  std::printf("  dimensions   %s\n", dims_text(h.dims).c_str());
  std::printf("  spacing      %s\n", spacing_text(h.spacing).c_str());
  std::printf("  origin       %s mm\n", vec_text(h.origin).c_str());
  std::printf("  axes         %s %s %s\n",
              vec_text({h.direction[0], h.direction[3], h.direction[6]}).c_str(),
              vec_text({h.direction[1], h.direction[4], h.direction[7]}).c_str(),
              vec_text({h.direction[2], h.direction[5], h.direction[8]}).c_str());
  std::printf("  voxels       %s%s\n", h.component_type.c_str(),
              h.compressed ? ", compressed" : "");
  if (!h.has_patient_orientation)
    std::printf("  note         no patient orientation in the header (axes taken as L, P, S)\n");
}

void list_dicom(const ImportCommandOptions& o) {
  CatalogOptions copt;
  copt.show_progress = !o.no_progress;
  copt.geometry.resampled_slice_spacing_mm = o.import.resampled_slice_spacing_mm;
  const DicomCatalog catalog = catalog_dicom(o.path, copt);
  const auto skipped = group_skipped(catalog);
  if (o.json) {
    nlohmann::ordered_json series = nlohmann::ordered_json::array();
    for (const auto& s : catalog.series) series.push_back(series_json(s));
    nlohmann::ordered_json skip = nlohmann::ordered_json::array();
    for (const auto& k : catalog.skipped)
      skip.push_back({{"path", display_path(k.path, catalog.root)}, {"reason", k.reason}});
    nlohmann::ordered_json j = {{"path", o.path},
                                {"discovered_by", catalog.discovered_by},
                                {"files_examined", catalog.files_examined},
                                {"series", series},
                                {"skipped", skip}};
    std::printf("%s\n", j.dump(2).c_str());
    return;
  }
  std::printf("%s: %s, %d file%s examined in %.2f s\n", o.path.c_str(),
              catalog.discovered_by.c_str(), catalog.files_examined,
              catalog.files_examined == 1 ? "" : "s", catalog.seconds);
  std::printf("%zu image series (%zu usable), %zu file%s skipped\n", catalog.series.size(),
              catalog.usable_series().size(), catalog.skipped.size(),
              catalog.skipped.size() == 1 ? "" : "s");
  int index = 0;
  for (const auto& s : catalog.series)
    print_series(s, ++index, static_cast<int>(catalog.series.size()));
  if (!skipped.empty()) {
    std::printf("\nskipped\n");
    for (const auto& [reason, names] : skipped) {
      std::string list;
      for (std::size_t i = 0; i < names.size() && i < 8; ++i) list += (i ? ", " : "") + names[i];
      if (names.size() > 8) list += ", … (" + std::to_string(names.size() - 8) + " more)";
      std::printf("  %s (%zu): %s\n", reason.c_str(), names.size(), list.c_str());
    }
  }
}

fs::path default_sidecar(const fs::path& output) {
  fs::path p = output;
  p.replace_extension(".json");
  return p;
}

void run_import(const ImportCommandOptions& o) {
  if (o.list) {
    if (fs::is_regular_file(o.path) && is_volume_file_path(o.path))
      list_volume_file(o);
    else
      list_dicom(o);
    return;
  }
  if (o.output.empty())
    throw Error("no output: give -o OUT.nrrd (or OUT.mha) to import, or --list to see the series");
  if (!is_writable_volume_path(o.output))
    throw Error("output '" + o.output + "': expected a .nrrd or .mha file name");
  const fs::path sidecar = o.sidecar.empty() ? default_sidecar(o.output) : fs::path(o.sidecar);
  if (sidecar == fs::path(o.output))
    throw Error("the sidecar and the volume would be the same file '" + o.output + "'");

  ImportOptions options = o.import;
  options.show_progress = !o.no_progress;
  options.max_voxels = static_cast<std::int64_t>(o.max_gigavoxels * 1e9);
  // Ctrl-C or SIGTERM: the decoders stop, nothing is written (or what was is removed), and the
  // command fails saying so. Temporaries of a write in progress are removed either way.
  InterruptScope interrupts;
  options.stop_requested = [] { return interrupted(); };
  auto stop_if_interrupted = [&](const std::vector<fs::path>& written) {
    if (!interrupted()) return;
    std::error_code ec;
    for (const fs::path& p : written) fs::remove(p, ec);
    throw Error("interrupted (signal " + std::to_string(interrupt_signal()) +
                "): nothing was written");
  };
  ImportResult result;
  try {
    result = import_volume(o.path, options);
  } catch (const Error&) {
    stop_if_interrupted({});
    throw;
  }
  stop_if_interrupted({});
  ImportReport& r = result.report;
  for (const auto& w : r.warnings) std::fprintf(stderr, "tsf import: warning: %s\n", w.c_str());

  Stopwatch write_clock;
  HuVolumeWriteOptions wopt;
  wopt.compress = !o.no_compress;
  r.output.stored_pixel_type = write_hu_volume(o.output, *result.image, wopt);
  r.output.file = o.output;
  r.seconds.write = write_clock.seconds();
  stop_if_interrupted({o.output});
  try {
    write_json_atomically(sidecar, import_report_to_json(r));
  } catch (...) {
    std::error_code ec;
    fs::remove(o.output, ec);  // no volume without its sidecar
    throw;
  }

  if (r.source.kind == "dicom")
    std::printf("imported series %s (%s, %d image%s) from %s\n",
                r.series.series_instance_uid.c_str(), r.series.modality.c_str(),
                r.source.files_used, r.source.files_used == 1 ? "" : "s", o.path.c_str());
  else
    std::printf("imported %s volume %s\n", r.source.kind.c_str(), o.path.c_str());
  const auto& a = r.acquisition;
  std::printf("  acquired   %s, %.3f × %.3f mm, slice gaps %s, tilt %.2f°\n",
              dims_text(a.dims).c_str(), a.pixel_spacing_x, a.pixel_spacing_y,
              describe_gap_runs(a.gaps).c_str(), a.tilt_deg);
  if (r.resampling.applied) {
    std::string reasons;
    for (const auto& x : r.resampling.reasons) reasons += (reasons.empty() ? "" : "; ") + x;
    std::printf("  resampled  %s (%.1f%% of voxels outside the acquired slices: %.0f)\n",
                reasons.c_str(), 100.0 * r.resampling.filled_fraction,
                static_cast<double>(r.resampling.fill_value));
  }
  std::printf("  volume     %s at %s, %s, %.0f .. %.0f %s\n", dims_text(r.output.dims).c_str(),
              spacing_text(r.output.spacing).c_str(), r.output.stored_pixel_type.c_str(),
              static_cast<double>(r.output.min_value), static_cast<double>(r.output.max_value),
              r.output.units.c_str());
  std::error_code ec;
  const auto bytes = fs::file_size(o.output, ec);
  std::printf("wrote %s (%.1f MB) and %s; import %.2f s, write %.2f s\n", o.output.c_str(),
              ec ? 0.0 : static_cast<double>(bytes) / 1e6, sidecar.string().c_str(),
              r.seconds.total, r.seconds.write);
}

constexpr const char* kImportFooter = R"(
Inputs
  A folder is walked recursively; every file is classified from its DICOM header (DCMTK) and
  image files are grouped by SeriesInstanceUID. A DICOMDIR (or any directory object such as
  Philips' DIRFILE) imports the files it references. A single DICOM file works when it is a
  whole volume (enhanced multi-frame CT). .nrrd/.nhdr, .mha/.mhd and .nii/.nii.gz are read
  through ITK. Uncompressed pixels (native, deflate) are decoded by tsf; compressed ones by
  GDCM (RLE, JPEG baseline/extended/lossless, JPEG-LS, JPEG 2000) in separate decoder
  processes with memory and CPU limits: a decoder that crashes, hangs or runs out of its
  limits fails the import naming the file, it cannot take tsf down. Each compressed frame's
  codestream is checked whole before decoding; decoder warnings of damaged data refuse it.

What is skipped, refused or repaired
  skipped   localizers/scouts, objects without pixels (reports, DICOMDIR), colour images;
            --list shows each with its reason.
  refused   a series that is not one volume: images of different sizes, orientations or
            pixel spacings, repeated SOP Instance UIDs, two slices at one position, several
            frames of reference, a gap over 10× the regular one (separate stacks), a
            damaged file of the series; a header claiming more voxels than --max-gvoxels or
            more bytes than the file holds (refused before allocating); non-CT without
            --any-modality.
  repaired  (refused instead with --strict) uneven slice spacing and missing slices: the
            stack is resampled to uniform spacing along the slice normal; gantry tilt: the
            sheared stack is resampled onto an orthogonal grid whose z axis is the table axis.
  Geometry always comes from ImagePositionPatient/ImageOrientationPatient, never from
  SliceThickness. Rescale slope/intercept (per file or per frame) or a Modality LUT is applied.

Outputs
  OUT.nrrd or OUT.mha in the LPS patient frame, int16 when every value is a whole number of HU
  (resampled values are rounded to whole HU: ≤ 0.5 HU, far below CT noise), else float32;
  OUT.json beside it: source and skipped files, series, acquired geometry (gaps, tilt, missing
  slices), output geometry, resampling, rescale, pixel decoding, warnings, seconds. Both are
  written atomically; Ctrl-C or SIGTERM stops the import and leaves neither (exit 1).
  No patient name, ID or birth date is written or printed.

Examples
  tsf import scans/ --list
  tsf import scans/ --series 1.2.840.113619.2.55.3 -o head.nrrd
  tsf import DICOMDIR -o head.mha --strict
  tsf import head.nii.gz -o head.nrrd
See docs/import.md.)";

}  // namespace

void add_import_command(CLI::App& app) {
  auto o = std::make_shared<ImportCommandOptions>();
  CLI::App* sub = app.add_subcommand(
      "import",
      "Read a CT (DICOM folder, DICOMDIR, enhanced multi-frame, NRRD, MHA, NIfTI) into one "
      "volume in Hounsfield units plus a JSON sidecar");
  sub->footer(kImportFooter);
  sub->add_option("PATH", o->path, "DICOM folder, DICOMDIR or file; or a .nrrd/.mha/.nii volume")
      ->required()
      ->check(CLI::ExistingPath);
  sub->add_option("-o,--output", o->output, "Output volume: OUT.nrrd or OUT.mha");
  sub->add_flag("-l,--list", o->list,
                "List the image series under PATH (UID, modality, description, images, "
                "dimensions, spacing, tilt) and what was skipped and why; writes nothing");
  sub->add_flag("--json", o->json, "With --list: print the listing as JSON");
  sub->add_option("-s,--series", o->import.series_uid,
                  "SeriesInstanceUID to import (needed when PATH holds several usable series)");
  sub->add_flag("--strict", o->import.strict,
                "Refuse a series that needs resampling (uneven spacing, missing slices, gantry "
                "tilt) instead of resampling it");
  sub->add_option("--slice-spacing", o->import.resampled_slice_spacing_mm,
                  "Slice spacing in mm when resampling (default: the most frequent slice gap)")
      ->check(CLI::PositiveNumber);
  sub->add_option("--sidecar", o->sidecar, "Where to write the JSON sidecar (default: OUT.json)");
  sub->add_flag("--any-modality", o->import.allow_non_ct,
                "Accept MR, PT, ... series (values stay in the modality's units, not HU)");
  sub->add_flag("--no-compress", o->no_compress, "Write the voxel data uncompressed (faster)");
  sub->add_flag("--no-progress", o->no_progress, "No progress bars (they show only on a terminal)");
  sub->add_option("--max-gvoxels", o->max_gigavoxels,
                  "Refuse volumes larger than this many 10^9 voxels (default 1)")
      ->check(CLI::PositiveNumber);
  sub->add_option("--threads", o->import.reader_threads,
                  "Threads decoding uncompressed DICOM files, and decoder processes for "
                  "compressed ones (default: all cores)")
      ->check(CLI::NonNegativeNumber);
  sub->callback([o] { run_import(*o); });
}

}  // namespace tsf::app
