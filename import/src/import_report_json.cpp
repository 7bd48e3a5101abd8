#include "tsf/import/import_report_json.h"

namespace tsf::import {
namespace {

using json = SidecarJson;

/// Adding 0.0 turns -0.0 (from cross products of axis vectors) into 0.0 for readers.
json vec(const Vec3d& v) {
  return json::array({v.x + 0.0, v.y + 0.0, v.z + 0.0});
}
json ivec(const Int3& v) {
  return json::array({v.x, v.y, v.z});
}

}  // namespace

SidecarJson import_report_to_json(const ImportReport& r) {
  json j;
  j["format"] = kImportSidecarFormat;

  json skipped = json::array();
  for (const auto& s : r.source.skipped)
    skipped.push_back({{"path", s.path}, {"reason", s.reason}});
  j["source"] = {{"path", r.source.path},
                 {"kind", r.source.kind},
                 {"discovered_by", r.source.discovered_by},
                 {"files_examined", r.source.files_examined},
                 {"files_used", r.source.files_used},
                 {"skipped", skipped},
                 {"other_series", r.source.other_series}};

  if (r.source.kind == "dicom")
    j["series"] = {{"series_instance_uid", r.series.series_instance_uid},
                   {"modality", r.series.modality},
                   {"description", r.series.description},
                   {"series_number", r.series.series_number},
                   {"manufacturer", r.series.manufacturer},
                   {"model_name", r.series.model_name},
                   {"sop_class", r.series.sop_class},
                   {"image_type", r.series.image_type},
                   {"frame_of_reference_uid", r.series.frame_of_reference_uid},
                   {"transfer_syntaxes", r.series.transfer_syntaxes},
                   {"enhanced_multiframe", r.series.enhanced_multiframe}};
  else
    j["series"] = nullptr;

  const auto& a = r.acquisition;
  json gaps = json::array();
  for (const auto& g : a.gaps) gaps.push_back({{"gap_mm", g.gap_mm}, {"count", g.count}});
  json missing = json::array();
  for (const auto& m : a.missing_slices)
    missing.push_back({{"after_slice", m.after_slice + 1},
                       {"gap_mm", m.gap_mm},
                       {"estimated_missing", m.estimated_missing}});
  j["acquisition"] = {
      {"dims", ivec(a.dims)},
      {"pixel_spacing_mm", json::array({a.pixel_spacing_x, a.pixel_spacing_y})},
      {"row_direction", vec(a.row)},
      {"column_direction", vec(a.column)},
      {"slice_normal", vec(a.normal)},
      {"first_position_mm", vec(a.first_position)},
      {"last_position_mm", vec(a.last_position)},
      {"span_along_normal_mm", a.span_along_normal_mm},
      {"slice_gaps", gaps},
      {"median_gap_mm", a.median_gap_mm},
      {"regular_gap_mm", a.regular_gap_mm},
      {"uneven_spacing", a.uneven_spacing},
      {"missing_slices", missing},
      {"gantry_tilt_deg", a.tilt_deg},
      {"gantry_tilted", a.tilted},
      {"max_in_plane_drift_mm", a.max_in_plane_drift_mm},
      {"gantry_tilt_tag_deg", a.gantry_tilt_tag_deg ? json(*a.gantry_tilt_tag_deg) : json(nullptr)},
      {"slice_thickness_tag_mm",
       a.slice_thickness_tag_mm ? json(*a.slice_thickness_tag_mm) : json(nullptr)},
      {"geometry_from", r.source.kind == "dicom"
                            ? "ImagePositionPatient and ImageOrientationPatient (SliceThickness "
                              "is reported only, never used)"
                            : "the file header"}};

  const auto& o = r.output;
  j["output"] = {{"file", o.file},
                 {"stored_pixel_type", o.stored_pixel_type},
                 {"dims", ivec(o.dims)},
                 {"spacing_mm", vec(o.spacing)},
                 {"origin_mm", vec(o.origin)},
                 {"direction", o.direction},
                 {"frame", "LPS"},
                 {"units", o.units},
                 {"min_value", o.min_value},
                 {"max_value", o.max_value},
                 {"integral_values", o.integral_values}};

  const auto& s = r.resampling;
  j["resampling"] = {{"applied", s.applied},
                     {"reasons", s.reasons},
                     {"method", s.method},
                     {"gantry_tilt_resolution", s.tilt_resolution},
                     {"slice_spacing_mm", s.slice_spacing_mm},
                     {"slice_spacing_rule", s.slice_spacing_rule},
                     {"fill_value", s.fill_value},
                     {"filled_fraction", s.filled_fraction},
                     {"rounded_to_integer", s.rounded_to_integer}};

  const auto& rs = r.rescale;
  j["rescale"] = {{"source", rs.source},
                  {"slope", rs.slope},
                  {"intercept", rs.intercept},
                  {"varies_between_slices", rs.varies_between_slices},
                  {"slope_range", json::array({rs.slope_min, rs.slope_max})},
                  {"intercept_range", json::array({rs.intercept_min, rs.intercept_max})},
                  {"rescale_type", rs.rescale_type},
                  {"pixel_representation", rs.pixel_representation},
                  {"bits_allocated", rs.bits_allocated},
                  {"bits_stored", rs.bits_stored},
                  {"modality_lut_applied", rs.modality_lut_applied}};
  if (r.source.kind == "dicom") {
    const auto& d = r.decoding;
    j["pixel_decoding"] = {{"native_files_decoded_by_tsf", d.native_files},
                           {"compressed_files_decoded_by_gdcm", d.compressed_files},
                           {"decoder_processes", d.decoder_processes},
                           {"decoder_limits", d.limits}};
  }
  j["warnings"] = r.warnings;
  j["seconds"] = {{"scan", r.seconds.scan},
                  {"read", r.seconds.read},
                  {"resample", r.seconds.resample},
                  {"write", r.seconds.write},
                  {"total", r.seconds.total}};
  return j;
}

}  // namespace tsf::import
