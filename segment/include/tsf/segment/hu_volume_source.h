// Where `tsf segment` gets its Hounsfield-unit volume from: the single place that reads input.
//
// It goes through tsf::import::import_volume(), so `tsf segment` reads whatever `tsf import`
// reads: a HU volume file (NRRD, MetaImage, NIfTI; e.g. data-samples/ct-head-cranium/cranium.nrrd
// or the output of `tsf import`) or a DICOM series (folder, file or DICOMDIR).
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "tsf/segment/segment_image_types.h"

namespace tsf::segment {

/// Reads `path` as a 3-D HU volume (any scalar pixel type, converted to float) or imports the
/// DICOM series at `path`. Throws tsf::Error naming the path when it is missing, not a readable
/// image or series, not 3-D, or holds non-finite values.
HuImage::Pointer read_hu_volume(const std::filesystem::path& path, bool show_progress = true);

/// The volume and what its import said about it: the warnings (resampled uneven spacing or
/// gantry tilt, no patient orientation recorded, ...) travel into segment's report.
struct HuVolumeInput {
  HuImage::Pointer image;
  std::vector<std::string> warnings;  ///< tsf::import::ImportReport::warnings
  std::string kind;                   ///< "dicom", "nrrd", "metaimage" or "nifti"
  std::string series_instance_uid;    ///< DICOM: the series that was imported
};

/// read_hu_volume with the import's warnings; `series_uid` picks a DICOM series when the path
/// holds several (empty: the only usable one).
HuVolumeInput import_hu_volume(const std::filesystem::path& path, const std::string& series_uid,
                               bool show_progress = true);

}  // namespace tsf::segment
