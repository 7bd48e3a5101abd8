#include "tsf/import/import_volume.h"

#include <omp.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <memory>
#include <new>
#include <set>

#include "compressed_frame_header.h"
#include "huge_pages.h"
#include "image_buffers.h"
#include "tsf/common/error.h"
#include "tsf/common/progress.h"
#include "tsf/common/stopwatch.h"
#include "tsf/common/text_format.h"
#include "tsf/import/ct_geometry.h"
#include "tsf/import/decoder_processes.h"
#include "tsf/import/dicom_catalog.h"
#include "tsf/import/dicom_pixel_reader.h"
#include "tsf/import/imaging_library_setup.h"
#include "tsf/import/slice_stack_resampler.h"
#include "tsf/import/volume_file_reader.h"
#include "tsf/import/volume_statistics.h"

namespace tsf::import {
namespace fs = std::filesystem;

namespace {

/// Lowest value a CT of a head or body shows (air, outside the patient); above it, the rescale
/// intercept was probably not applied.
constexpr float kAirCeilingHu = -900.0f;

std::string dims_text(const Int3& d) {
  return std::to_string(d.x) + "×" + std::to_string(d.y) + "×" + std::to_string(d.z);
}

void check_voxel_budget(const Int3& dims, std::int64_t max_voxels, const std::string& what) {
  if (dims.volume() > max_voxels)
    throw Error(what + " would hold " + dims_text(dims) + " = " + std::to_string(dims.volume()) +
                " voxels, more than the limit of " + std::to_string(max_voxels) +
                ": refused before allocating");
}

/// "\n  skipped: 3 × not DICOM; ..." (empty when nothing was skipped).
std::string skipped_summary(const DicomCatalog& catalog) {
  std::map<std::string, int> reasons;
  for (const auto& k : catalog.skipped) ++reasons[k.reason];
  std::string out;
  for (const auto& [reason, count] : reasons)
    out += "\n  skipped " + std::to_string(count) + " × " + reason;
  return out;
}

const DicomSeries& select_series(const DicomCatalog& catalog, const ImportOptions& options) {
  const std::string where = "'" + catalog.root.string() + "'";
  auto list_all = [&] {
    std::string out;
    for (const auto& s : catalog.series) out += "\n  " + one_line_summary(s);
    return out;
  };
  if (!options.series_uid.empty()) {
    const DicomSeries* s = catalog.find(options.series_uid);
    if (!s)
      throw Error("no series with SeriesInstanceUID " + options.series_uid + " under " + where +
                  (catalog.series.empty() ? std::string(": no image series found")
                                          : "; series found:" + list_all()));
    if (!s->usable()) {
      std::string problems;
      for (const auto& p : s->problems) problems += "\n  - " + p;
      throw Error("series " + s->series_instance_uid + " under " + where +
                  " is not one volume:" + problems);
    }
    return *s;
  }
  const auto usable = catalog.usable_series();
  if (usable.size() == 1) return *usable.front();
  if (usable.size() > 1)
    throw Error(where + " holds " + std::to_string(usable.size()) +
                " usable series; choose one with --series UID:" + list_all());
  if (!catalog.series.empty()) {
    std::string out;
    for (const auto& s : catalog.series) {
      out += "\n  series " +
             (s.series_instance_uid.empty() ? std::string("(no UID)") : s.series_instance_uid) +
             " (" + std::to_string(s.image_count()) + " images):";
      for (const auto& p : s.problems) out += "\n    - " + p;
    }
    throw Error("no usable image series under " + where + " (" +
                std::to_string(catalog.files_examined) + " files examined):" + out +
                skipped_summary(catalog));
  }
  throw Error("no DICOM image series under " + where + " (" +
              std::to_string(catalog.files_examined) + " files examined)" +
              skipped_summary(catalog));
}

void fill_acquisition(const DicomSeries& s, const SliceStackGeometry& g, ImportReport& r) {
  auto& a = r.acquisition;
  a.dims = {g.columns, g.rows, g.slice_count()};
  a.pixel_spacing_x = g.spacing_x;
  a.pixel_spacing_y = g.spacing_y;
  a.row = g.axes.row;
  a.column = g.axes.column;
  a.normal = g.normal;
  a.first_position = g.sorted_positions.front();
  a.last_position = g.sorted_positions.back();
  a.span_along_normal_mm = g.offsets_mm.back();
  a.gaps = g.gap_runs;
  a.median_gap_mm = g.median_gap_mm;
  a.regular_gap_mm = g.regular_gap_mm;
  a.uneven_spacing = g.uneven;
  a.missing_slices = g.missing;
  a.tilt_deg = g.tilt_deg;
  a.max_in_plane_drift_mm = g.max_drift_mm;
  a.tilted = g.tilted;
  const DicomFileInfo& f = s.files.front();
  if (f.has_gantry_tilt) a.gantry_tilt_tag_deg = f.gantry_tilt_deg;
  if (f.has_slice_thickness) a.slice_thickness_tag_mm = f.slice_thickness_mm;
}

void fill_series(const DicomCatalog& catalog, const DicomSeries& s, ImportReport& r) {
  const DicomFileInfo& f = s.files.front();
  auto& id = r.series;
  id.series_instance_uid = s.series_instance_uid;
  id.modality = s.modality;
  id.description = s.description;
  id.series_number = s.series_number;
  id.manufacturer = f.manufacturer;
  id.model_name = f.model_name;
  id.sop_class = dicom_uid_name(f.sop_class_uid);
  id.image_type = f.image_type;
  id.frame_of_reference_uid = f.frame_of_reference_uid;
  std::set<std::string> seen;
  for (const auto& file : s.files) {
    if (seen.insert(file.transfer_syntax_uid).second)
      id.transfer_syntaxes.push_back(dicom_uid_name(file.transfer_syntax_uid));
    id.enhanced_multiframe = id.enhanced_multiframe || file.enhanced;
  }
  auto& src = r.source;
  src.kind = "dicom";
  src.discovered_by = catalog.discovered_by;
  src.files_examined = catalog.files_examined;
  src.files_used = s.image_count();
  for (const auto& k : catalog.skipped)
    src.skipped.push_back({display_path(k.path, catalog.root), k.reason});
  for (const auto& other : catalog.series)
    if (&other != &s) src.other_series.push_back(one_line_summary(other));
}

void add_geometry_warnings(const DicomSeries& s, const SliceStackGeometry& g, ImportReport& r) {
  for (const auto& m : g.missing)
    r.warnings.push_back("gap of " + format_text("%.2f", m.gap_mm) + " mm after slice " +
                         std::to_string(m.after_slice + 1) + " (regular gap " +
                         format_text("%.2f", g.regular_gap_mm) + " mm): about " +
                         std::to_string(m.estimated_missing) +
                         " missing slice(s), interpolated across");
  if (g.uneven)
    r.warnings.push_back("uneven slice spacing: gaps " + describe_gap_runs(g.gap_runs) +
                         " along the slice normal; resampled to uniform spacing");
  if (g.tilted)
    r.warnings.push_back("gantry tilt of " + format_text("%.2f", g.tilt_deg) +
                         "° (slice positions drift " + format_text("%.1f", g.max_drift_mm) +
                         " mm in-plane); resampled onto an orthogonal grid");
  const DicomFileInfo& f = s.files.front();
  if (f.has_gantry_tilt && std::abs(std::abs(f.gantry_tilt_deg) - g.tilt_deg) > 0.5)
    r.warnings.push_back("GantryDetectorTilt (0018,1120) says " +
                         format_text("%.2f", f.gantry_tilt_deg) +
                         "° but the slice positions show " + format_text("%.2f", g.tilt_deg) +
                         "°: the positions were used");
}

/// Decodes every slice of `s` into `stack` in the sorted order of `g` (slice k at
/// stack + k·plane). Uncompressed files are decoded by tsf in parallel threads; compressed ones
/// by GDCM in decoder processes (decoder_processes.h), or here, one at a time, when
/// TSF_DECODE_IN_PROCESS=1.
void read_series_pixels(const DicomSeries& s, const SliceStackGeometry& g,
                        const ImportOptions& options, float* stack, ImportReport& r) {
  const std::size_t plane = static_cast<std::size_t>(g.columns) * g.rows;
  std::vector<int> slot(static_cast<std::size_t>(s.slice_count()));
  for (int k = 0; k < g.slice_count(); ++k) slot[static_cast<std::size_t>(g.sorted[k])] = k;
  std::vector<std::vector<int>> slices_of_file(s.files.size());
  for (int i = 0; i < s.slice_count(); ++i) slices_of_file[s.slices[i].file].push_back(i);
  auto stopped = [&] { return options.stop_requested && options.stop_requested(); };

  const int n_files = static_cast<int>(s.files.size());
  std::vector<std::string> errors(s.files.size());
  std::vector<DecodedFrameValues> decoded(s.files.size());
  Progress progress("reading " + std::to_string(g.slice_count()) + " slices",
                    static_cast<std::uint64_t>(g.slice_count()),
                    options.show_progress && Progress::stderr_is_terminal());
  const int threads = options.reader_threads > 0 ? options.reader_threads : omp_get_max_threads();
  const bool isolated = decoders_isolated();
  std::vector<int> compressed;
  for (int f = 0; f < n_files; ++f)
    if (s.files[static_cast<std::size_t>(f)].pixel_data_encapsulated) compressed.push_back(f);
  auto decode_here = [&](int f) {
    const DicomFileInfo& info = s.files[static_cast<std::size_t>(f)];
    if (stopped()) return;
    try {
      if (info.number_of_frames == 1) {
        decoded[f] = decode_dicom_frames(info, stack + slot[slices_of_file[f][0]] * plane);
      } else {
        std::vector<float> frames(plane * static_cast<std::size_t>(info.number_of_frames));
        decoded[f] = decode_dicom_frames(info, frames.data());
        for (int i : slices_of_file[f])
          std::copy_n(frames.data() + static_cast<std::size_t>(s.slices[i].frame) * plane, plane,
                      stack + static_cast<std::size_t>(slot[i]) * plane);
      }
    } catch (const std::exception& e) {
      errors[f] = e.what();
    }
    progress.advance(slices_of_file[f].size());
  };
#pragma omp parallel for schedule(dynamic, 1) num_threads(threads)
  for (int f = 0; f < n_files; ++f)
    if (!isolated || !s.files[static_cast<std::size_t>(f)].pixel_data_encapsulated) decode_here(f);
  for (const auto& e : errors)
    if (!e.empty()) throw Error(e);
  if (stopped()) throw Error("interrupted");

  if (isolated && !compressed.empty()) {
    // Frame k of file f goes to the slot of its slice.
    std::vector<std::vector<int>> slice_of_frame(s.files.size());
    for (int i = 0; i < s.slice_count(); ++i) {
      auto& frames = slice_of_frame[s.slices[i].file];
      const auto& info = s.files[static_cast<std::size_t>(s.slices[i].file)];
      frames.resize(static_cast<std::size_t>(info.number_of_frames), -1);
      frames[static_cast<std::size_t>(s.slices[i].frame)] = i;
    }
    std::vector<const DicomFileInfo*> files;
    for (int f : compressed) files.push_back(&s.files[static_cast<std::size_t>(f)]);
    DecoderProcessOptions dopt;
    dopt.processes = threads;
    dopt.stop_requested = options.stop_requested;
    r.decoding.decoder_processes = std::min<int>(threads, static_cast<int>(files.size()));
    decode_in_processes(
        files, dopt,
        [&](int job, int frame) -> float* {
          const auto& frames = slice_of_frame[static_cast<std::size_t>(compressed[job])];
          const int i = static_cast<std::size_t>(frame) < frames.size() ? frames[frame] : -1;
          return i < 0 ? nullptr : stack + static_cast<std::size_t>(slot[i]) * plane;
        },
        [&](int job, const DecodedFrameValues& v) {
          decoded[static_cast<std::size_t>(compressed[job])] = v;
          progress.advance(slices_of_file[compressed[job]].size());
        });
  }
  progress.finish();
  r.decoding.native_files = n_files - static_cast<int>(compressed.size());
  r.decoding.compressed_files = static_cast<int>(compressed.size());
  if (r.decoding.decoder_processes > 0) r.decoding.limits = decoder_process_limits_text();
  if (!isolated && !compressed.empty())
    r.warnings.push_back(
        "compressed pixel data were decoded inside tsf (TSF_DECODE_IN_PROCESS=1), not in decoder "
        "processes: a codec failure would have ended tsf");

  auto& rs = r.rescale;
  const DicomFileInfo& first = s.files.front();
  rs.pixel_representation = first.pixel_representation ? "signed" : "unsigned";
  rs.bits_allocated = first.bits_allocated;
  rs.bits_stored = first.bits_stored;
  rs.rescale_type = first.rescale_type;
  bool any_rescale = false, first_seen = false;
  for (std::size_t f = 0; f < s.files.size(); ++f) {
    rs.modality_lut_applied = rs.modality_lut_applied || decoded[f].modality_lut_applied;
    if (decoded[f].modality_lut_applied && rs.rescale_type.empty())
      rs.rescale_type = decoded[f].modality_lut_type;
    for (const auto& fr : s.files[f].frames) {
      const double m = fr.has_rescale ? fr.rescale_slope : 1.0;
      const double b = fr.has_rescale ? fr.rescale_intercept : 0.0;
      any_rescale = any_rescale || fr.has_rescale;
      if (!first_seen) {
        rs.slope = rs.slope_min = rs.slope_max = m;
        rs.intercept = rs.intercept_min = rs.intercept_max = b;
        first_seen = true;
      }
      rs.slope_min = std::min(rs.slope_min, m);
      rs.slope_max = std::max(rs.slope_max, m);
      rs.intercept_min = std::min(rs.intercept_min, b);
      rs.intercept_max = std::max(rs.intercept_max, b);
    }
    if (s.files[f].pixel_representation != first.pixel_representation)
      rs.pixel_representation = "mixed (per file)";
  }
  rs.varies_between_slices = rs.slope_min != rs.slope_max || rs.intercept_min != rs.intercept_max;
  if (rs.modality_lut_applied)
    rs.source = "Modality LUT Sequence (0028,3000)";
  else if (!any_rescale)
    rs.source = "none in the files: stored values used as they are";
  else if (first.enhanced)
    rs.source = "Pixel Value Transformation functional group (per frame)";
  else
    rs.source = "RescaleSlope/RescaleIntercept (0028,1053/1052) of each file";
}

HuImage::Pointer import_dicom(const fs::path& path, const ImportOptions& options, ImportReport& r) {
  Stopwatch clock;
  CatalogOptions copt;
  copt.geometry.resampled_slice_spacing_mm = options.resampled_slice_spacing_mm;
  copt.show_progress = options.show_progress;
  const DicomCatalog catalog = catalog_dicom(path, copt);
  r.seconds.scan = catalog.seconds;
  const DicomSeries& s = select_series(catalog, options);
  fill_series(catalog, s, r);
  const SliceStackGeometry& g = *s.geometry;
  fill_acquisition(s, g, r);

  if (s.modality != "CT" && !options.allow_non_ct)
    throw Error("series " + s.series_instance_uid + " under '" + path.string() + "' has modality " +
                (s.modality.empty() ? std::string("(none)") : s.modality) +
                ": its values are not Hounsfield units. Import a CT, or allow other modalities "
                "(--any-modality) to keep the modality's own units");
  if (s.modality != "CT") {
    r.output.units =
        (s.modality.empty() ? std::string("unknown") : s.modality) + " modality units (not HU)";
    r.warnings.push_back("modality " + s.modality + ": values are not Hounsfield units");
  }
  if (options.strict && g.needs_resampling) {
    std::string reasons;
    for (const auto& reason : g.resampling_reasons) reasons += "\n  - " + reason;
    for (const auto& m : g.missing)
      reasons += "\n  - gap of " + format_text("%.2f", m.gap_mm) + " mm after slice " +
                 std::to_string(m.after_slice + 1) + ": about " +
                 std::to_string(m.estimated_missing) + " missing slice(s)";
    throw Error("series " + s.series_instance_uid + " under '" + path.string() +
                "' would need resampling, refused (strict):" + reasons);
  }
  add_geometry_warnings(s, g, r);

  const std::string series_name =
      "series " + s.series_instance_uid + " under '" + path.string() + "'";
  const Int3 stack_dims{g.columns, g.rows, g.slice_count()};
  check_voxel_budget(stack_dims, options.max_voxels, series_name);
  if (g.needs_resampling)
    check_voxel_budget(g.grid.dims, options.max_voxels, "the resampled grid of " + series_name);

  // Compressed files together may claim no more than they can hold (compressed_frame_header.h).
  std::uint64_t declared = 0, compressed_bytes = 0;
  for (const DicomFileInfo& f : s.files)
    if (f.pixel_data_encapsulated) {
      declared += f.decoded_bytes();
      compressed_bytes += f.pixel_data_bytes;
    }
  const std::string ratio = compression_ratio_problem(declared, compressed_bytes);
  if (!ratio.empty()) throw Error(series_name + ": its compressed files declare " + ratio);

  const std::size_t plane = static_cast<std::size_t>(g.columns) * g.rows;
  HuImage::Pointer image;
  std::unique_ptr<float[]> stack;  // not value-initialised: every value is decoded into it
  float* stack_data = nullptr;
  if (g.needs_resampling) {
    try {
      stack.reset(new float[plane * static_cast<std::size_t>(g.slice_count())]);
      advise_huge_pages(stack.get(), plane * static_cast<std::size_t>(g.slice_count()) * 4);
    } catch (const std::bad_alloc&) {
      throw Error("not enough memory for the " + dims_text(stack_dims) + " slices of " +
                  series_name);
    }
    stack_data = stack.get();
  } else {
    image = make_hu_image(g.grid);
    stack_data = image->GetBufferPointer();
  }
  r.seconds.scan = clock.seconds();
  clock.restart();
  read_series_pixels(s, g, options, stack_data, r);
  const VolumeStatistics acquired =
      volume_statistics(stack_data, plane * static_cast<std::size_t>(g.slice_count()));
  if (acquired.non_finite > 0)
    throw Error(series_name + ": " + std::to_string(acquired.non_finite) +
                " decoded values are not finite");
  r.seconds.read = clock.seconds();

  auto& rs = r.resampling;
  ResampleStatistics resampled;
  if (g.needs_resampling) {
    clock.restart();
    image = make_hu_image(g.grid);
    SliceStackSamples in;
    in.values = stack_data;
    in.columns = g.columns;
    in.rows = g.rows;
    in.slices = g.slice_count();
    in.positions = g.sorted_positions.data();
    in.row = g.axes.row;
    in.column = g.axes.column;
    in.spacing_x = g.spacing_x;
    in.spacing_y = g.spacing_y;
    rs.applied = true;
    rs.reasons = g.resampling_reasons;
    rs.fill_value = acquired.min;
    rs.method =
        "trilinear: bilinear on the two acquired planes that bracket each voxel along the slice "
        "normal, linear between them";
    rs.tilt_resolution = g.tilt_resolution;
    rs.slice_spacing_mm = g.grid.spacing.z;
    rs.slice_spacing_rule = options.resampled_slice_spacing_mm > 0
                                ? "requested (" +
                                      format_text("%.3f", options.resampled_slice_spacing_mm) +
                                      " mm), adjusted so whole slices span the volume"
                                : std::string("the most frequent slice gap") +
                                      (g.tilted ? " along the table axis" : "") +
                                      ", adjusted so whole slices span the volume";
    Progress progress("resampling", static_cast<std::uint64_t>(g.grid.dims.z),
                      options.show_progress && Progress::stderr_is_terminal());
    // A source of whole numbers (CT HU are integers) is rounded to whole numbers after
    // interpolation so the volume stores as int16; the error (≤ 0.5 HU) is far below CT noise.
    ResampleOptions ro;
    ro.fill_value = rs.fill_value;
    ro.round_to_integer = rs.rounded_to_integer =
        acquired.integral && acquired.min >= -4194304.0f && acquired.max <= 4194304.0f;
    resampled = resample_slice_stack(in, g.grid, ro, image->GetBufferPointer(), &progress);
    progress.finish();
    const std::size_t n = static_cast<std::size_t>(g.grid.dims.volume());
    rs.filled_fraction = static_cast<double>(resampled.filled_voxels) / static_cast<double>(n);
    r.seconds.resample = clock.seconds();
  }

  VolumeStatistics out_stats = acquired;
  if (g.needs_resampling) {
    out_stats.min = resampled.min;
    out_stats.max = resampled.max;
    out_stats.integral = resampled.integral;
  }
  auto& o = r.output;
  o.dims = g.grid.dims;
  o.spacing = g.grid.spacing;
  o.origin = g.grid.origin;
  for (int a = 0; a < 3; ++a)
    for (int row = 0; row < 3; ++row) o.direction[row * 3 + a] = g.grid.axes[a][row];
  o.min_value = out_stats.min;
  o.max_value = out_stats.max;
  o.integral_values = out_stats.integral;
  r.source.path = path.string();
  return image;
}

}  // namespace

HuImage::Pointer make_hu_image(const OrthogonalGrid& grid) {
  auto image = HuImage::New();
  HuImage::RegionType region;
  region.SetSize({static_cast<itk::SizeValueType>(grid.dims.x),
                  static_cast<itk::SizeValueType>(grid.dims.y),
                  static_cast<itk::SizeValueType>(grid.dims.z)});
  image->SetRegions(region);
  HuImage::SpacingType spacing;
  HuImage::PointType origin;
  HuImage::DirectionType direction;
  for (int a = 0; a < 3; ++a) {
    spacing[a] = grid.spacing[a];
    origin[a] = grid.origin[a];
    for (int r = 0; r < 3; ++r) direction[r][a] = grid.axes[a][r];
  }
  image->SetSpacing(spacing);
  image->SetOrigin(origin);
  image->SetDirection(direction);
  try {
    image->Allocate();
  } catch (const std::bad_alloc&) {
    throw Error("not enough memory for a " + dims_text(grid.dims) + " volume");
  } catch (const itk::ExceptionObject& e) {
    throw Error("cannot allocate a " + dims_text(grid.dims) + " volume: " + e.GetDescription());
  }
  advise_huge_pages(image->GetBufferPointer(),
                    static_cast<std::size_t>(grid.dims.volume()) * sizeof(float));
  return image;
}

namespace {
template <typename T>
void to_float(const void* src, std::size_t n, float* out) {
  const T* s = static_cast<const T*>(src);
  for (std::size_t i = 0; i < n; ++i) out[i] = static_cast<float>(s[i]);
}
}  // namespace

bool convert_to_float(itk::CommonEnums::IOComponent type, const void* src, std::size_t n,
                      float* out) {
  using Component = itk::CommonEnums::IOComponent;
  switch (type) {
    case Component::UCHAR:
      to_float<unsigned char>(src, n, out);
      return true;
    case Component::CHAR:
      to_float<signed char>(src, n, out);
      return true;
    case Component::USHORT:
      to_float<std::uint16_t>(src, n, out);
      return true;
    case Component::SHORT:
      to_float<std::int16_t>(src, n, out);
      return true;
    case Component::UINT:
      to_float<std::uint32_t>(src, n, out);
      return true;
    case Component::INT:
      to_float<std::int32_t>(src, n, out);
      return true;
    case Component::ULONG:
      to_float<unsigned long>(src, n, out);
      return true;
    case Component::LONG:
      to_float<long>(src, n, out);
      return true;
    case Component::ULONGLONG:
      to_float<unsigned long long>(src, n, out);
      return true;
    case Component::LONGLONG:
      to_float<long long>(src, n, out);
      return true;
    case Component::FLOAT:
      to_float<float>(src, n, out);
      return true;
    case Component::DOUBLE:
      to_float<double>(src, n, out);
      return true;
    default:
      return false;
  }
}

const DicomSeries& select_dicom_series(const DicomCatalog& catalog, const ImportOptions& options) {
  return select_series(catalog, options);
}

ImportResult import_volume(const fs::path& path, const ImportOptions& options) {
  Stopwatch total;
  setup_imaging_libraries();
  std::error_code ec;
  if (!fs::exists(path, ec)) throw Error("'" + path.string() + "' does not exist");
  if (!(options.max_voxels > 0)) throw Error("ImportOptions::max_voxels must be positive");
  ImportResult result;
  if (fs::is_regular_file(path, ec) && is_volume_file_path(path)) {
    if (!options.series_uid.empty())
      throw Error("a series UID (" + options.series_uid + ") was given but '" + path.string() +
                  "' is a volume file, not DICOM");
    result.image = read_volume_file(path, options, result.report);
  } else {
    result.image = import_dicom(path, options, result.report);
  }

  const auto& o = result.report.output;
  if (o.units == "HU" && o.min_value > kAirCeilingHu)
    result.report.warnings.push_back(
        "the lowest value is " + format_text("%.0f", static_cast<double>(o.min_value)) +
        " HU: no air in the volume (air is about -1000 HU); check that the values are HU and "
        "that the rescale intercept was applied");
  result.report.seconds.total = total.seconds();
  return result;
}

}  // namespace tsf::import
