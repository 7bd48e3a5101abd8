// What one DICOM file is, read from its header with DCMTK (pixel data are not loaded).
//
// Classic single-frame images and enhanced multi-frame objects are described alike: one
// DicomFrameInfo per frame, filled from the per-frame functional groups, the shared functional
// groups, or the top-level attributes, in that order of precedence (PS3.3 C.7.6.16).
//
// No patient-identifying attribute (name, ID, birth date, ...) is ever read into this struct,
// so nothing downstream can print one.
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "tsf/common/vec3.h"

namespace tsf::import {

enum class DicomObjectKind {
  image,        ///< a grey-scale image: a candidate slice of a volume
  localizer,    ///< scout / localizer / topogram image: never part of a volume
  unsupported,  ///< an image tsf cannot use as CT (colour, float pixel data, ...)
  non_image,    ///< no pixel data (structured report, presentation state, ...)
  directory,    ///< DICOMDIR (Media Storage Directory) object
  not_dicom,    ///< not a DICOM file
  unreadable,   ///< looks like DICOM but its header cannot be parsed
};
const char* to_string(DicomObjectKind kind);

struct DicomFrameInfo {
  bool has_position = false;
  Vec3d position;  ///< ImagePositionPatient, centre of the first pixel, mm, LPS
  bool has_orientation = false;
  Vec3d row{1, 0, 0};     ///< ImageOrientationPatient[0..2]
  Vec3d column{0, 1, 0};  ///< ImageOrientationPatient[3..5]
  bool has_pixel_spacing = false;
  double spacing_between_rows = 0;     ///< PixelSpacing[0], mm (along `column`)
  double spacing_between_columns = 0;  ///< PixelSpacing[1], mm (along `row`)
  bool has_rescale = false;
  double rescale_slope = 1;
  double rescale_intercept = 0;
};

struct DicomFileInfo {
  std::filesystem::path path;
  DicomObjectKind kind = DicomObjectKind::not_dicom;
  std::string skip_reason;  ///< why the file is not a volume slice (empty for kind == image)

  std::string sop_class_uid, sop_instance_uid, series_instance_uid, frame_of_reference_uid;
  std::string transfer_syntax_uid;
  std::string modality, series_description, series_number, manufacturer, model_name;
  std::string image_type;  ///< values joined by '\'
  std::string photometric_interpretation;
  bool has_instance_number = false;
  long instance_number = 0;

  int rows = 0, columns = 0, number_of_frames = 1, samples_per_pixel = 1;
  int bits_allocated = 0, bits_stored = 0, high_bit = 0, pixel_representation = 0;

  bool enhanced = false;               ///< functional groups present (enhanced multi-frame IOD)
  std::vector<DicomFrameInfo> frames;  ///< number_of_frames entries

  bool has_gantry_tilt = false;
  double gantry_tilt_deg = 0;  ///< GantryDetectorTilt (0018,1120), reported only
  bool has_slice_thickness = false;
  double slice_thickness_mm = 0;  ///< reported only: never used for geometry
  std::string rescale_type;       ///< RescaleType (0028,1054), e.g. "HU"
  bool has_modality_lut = false;  ///< Modality LUT Sequence (0028,3000)
  bool has_pixel_padding_value = false;
  double pixel_padding_value = 0;

  bool has_pixel_data = false;
  bool pixel_data_encapsulated = false;  ///< compressed transfer syntax
  /// Native pixel data: the value length; encapsulated: the bytes of all fragments.
  std::uint64_t pixel_data_bytes = 0;

  /// Bytes the decoded pixel data occupy: rows·columns·frames·samples·ceil(bits_allocated/8).
  std::uint64_t decoded_bytes() const;
};

/// Reads the header of `path`. Never throws for bad input: a file that is not usable is returned
/// with its kind and a skip_reason that says why. Throws only for I/O errors such as a
/// missing file.
DicomFileInfo read_dicom_file_info(const std::filesystem::path& path);

/// True when the file starts like DICOM: a Part 10 preamble ("DICM" at byte 128) or a raw data
/// set beginning with a group 0002/0008 tag.
bool looks_like_dicom(const std::filesystem::path& path);

/// Files referenced by a DICOMDIR (any Media Storage Directory object). Referenced File IDs are
/// resolved against the DICOMDIR's folder and, when absent there, against its parent folders
/// (some scanners write the IDs relative to the media root). Files that cannot be found are
/// returned in `missing` as the ID as written.
struct DicomDirContents {
  std::vector<std::filesystem::path> files;
  std::vector<std::string> missing;
};
DicomDirContents read_dicomdir(const std::filesystem::path& dicomdir);

/// Name of a UID from DCMTK's dictionary ("CT Image Storage"), or the UID itself.
std::string dicom_uid_name(const std::string& uid);

}  // namespace tsf::import
