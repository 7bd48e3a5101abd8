// What an import did, for the JSON sidecar written beside every imported volume
// (import_report_json.h) and for callers that need the provenance of a HU volume.
//
// Patient name, ID and birth date are never part of it.
#pragma once

#include <array>
#include <optional>
#include <string>
#include <vector>

#include "tsf/common/vec3.h"
#include "tsf/import/slice_stack_geometry.h"

namespace tsf::import {

struct ImportReport {
  struct Source {
    std::string path;           ///< as given to import_volume
    std::string kind;           ///< "dicom", "nrrd", "metaimage" or "nifti"
    std::string discovered_by;  ///< DICOM: "folder", "DICOMDIR" or "file"
    int files_examined = 0;     ///< files looked at (DICOM: every file under the path)
    int files_used = 0;         ///< files whose pixels are in the volume
    struct Skipped {
      std::string path, reason;
    };
    std::vector<Skipped> skipped;  ///< files not used, and why
    /// Other series under the path that were not imported, one line each with their status.
    std::vector<std::string> other_series;
  } source;

  /// DICOM series identity (empty strings for NRRD/MHA/NIfTI).
  struct Series {
    std::string series_instance_uid, modality, description, series_number;
    std::string manufacturer, model_name, sop_class, image_type, frame_of_reference_uid;
    std::vector<std::string> transfer_syntaxes;  ///< names, each once
    bool enhanced_multiframe = false;
  } series;

  /// The acquired slices as found in the headers (DICOM) or the file header.
  struct Acquisition {
    Int3 dims;                            ///< columns, rows, slices
    double pixel_spacing_x = 0;           ///< mm between columns
    double pixel_spacing_y = 0;           ///< mm between rows
    Vec3d row, column, normal;            ///< unit, LPS
    Vec3d first_position, last_position;  ///< ImagePositionPatient of the first/last slice, mm
    double span_along_normal_mm = 0;      ///< distance first -> last slice along the normal
    std::vector<SliceGapRun> gaps;        ///< slice gaps along the normal
    double median_gap_mm = 0, regular_gap_mm = 0;
    bool uneven_spacing = false;
    std::vector<MissingSlicesGap> missing_slices;
    double tilt_deg = 0;  ///< measured from the positions
    double max_in_plane_drift_mm = 0;
    bool tilted = false;
    std::optional<double> gantry_tilt_tag_deg;     ///< GantryDetectorTilt as written (not used)
    std::optional<double> slice_thickness_tag_mm;  ///< SliceThickness as written (not used)
  } acquisition;

  /// The volume returned (and written).
  struct Output {
    Int3 dims;
    Vec3d spacing;  ///< mm
    Vec3d origin;   ///< centre of voxel (0,0,0), mm, LPS
    std::array<double, 9> direction{1, 0, 0, 0, 1, 0, 0, 0, 1};  ///< row-major, columns = axes
    float min_value = 0, max_value = 0;
    bool integral_values = false;   ///< every value is an integer (written as int16 if it fits)
    std::string units = "HU";       ///< "HU", or the modality's units with allow_non_ct
    std::string file;               ///< where it was written (empty until written)
    std::string stored_pixel_type;  ///< "int16" or "float32" once written
  } output;

  struct Resampling {
    bool applied = false;
    std::vector<std::string> reasons;  ///< "gantry tilt 18.50°", "uneven slice spacing (...)"
    std::string method;                ///< how values were interpolated
    std::string tilt_resolution;       ///< how a gantry tilt was resolved (empty if none)
    double slice_spacing_mm = 0;       ///< output spacing along the stack
    std::string slice_spacing_rule;    ///< why that spacing
    float fill_value = 0;              ///< value of voxels outside the acquired planes
    double filled_fraction = 0;        ///< share of voxels that got fill_value
    bool rounded_to_integer = false;   ///< values rounded to whole HU after interpolation
  } resampling;

  struct Rescale {
    std::string source;               ///< where the modality transform came from
    double slope = 1, intercept = 0;  ///< first slice's (or the file's) values
    bool varies_between_slices = false;
    double slope_min = 1, slope_max = 1, intercept_min = 0, intercept_max = 0;
    std::string rescale_type;          ///< RescaleType (0028,1054) when present
    std::string pixel_representation;  ///< "signed", "unsigned" (DICOM) or the file's type
    int bits_allocated = 0, bits_stored = 0;
    bool modality_lut_applied = false;
  } rescale;

  /// How the DICOM pixel data were decoded (robustness.md, "Containment of the decoders").
  struct Decoding {
    int native_files = 0;       ///< uncompressed: decoded by tsf itself
    int compressed_files = 0;   ///< decoded by GDCM's codecs
    int decoder_processes = 0;  ///< isolated processes that ran the codecs (0: inside tsf)
    std::string limits;         ///< the per-file limits of a decoder process, in words
  } decoding;

  std::vector<std::string> warnings;

  struct Seconds {
    double scan = 0, read = 0, resample = 0, write = 0, total = 0;  ///< total: import, not write
  } seconds;
};

}  // namespace tsf::import
