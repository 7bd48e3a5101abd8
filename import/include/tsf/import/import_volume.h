// import_volume: a CT scan on disk -> one volume in Hounsfield units with its true geometry.
//
// Inputs: a DICOM folder (walked recursively), a DICOMDIR, a single DICOM file (an enhanced
// multi-frame CT), or an NRRD (.nrrd/.nhdr), MetaImage (.mha/.mhd) or NIfTI (.nii/.nii.gz) file.
//
// DICOM: headers are read with DCMTK, pixels through ITK + GDCM (every transfer syntax GDCM
// decodes). Geometry comes from ImagePositionPatient/ImageOrientationPatient, never from
// SliceThickness. Rescale slope/intercept (per slice or per frame), a Modality LUT, signed,
// unsigned and 12-bit stored pixels are applied, so values are HU. A series that needs it
// (gantry tilt, uneven spacing, missing slices) is resampled onto an orthogonal grid (see
// slice_stack_geometry.h); `strict` refuses it instead. Localizers and non-image objects are
// skipped; a series that is not one volume is refused with the reason.
//
// Output geometry: LPS patient frame, mm. The image's direction matrix is orthonormal (never
// sheared), so voxels are axis-aligned boxes in their own index frame, as segment/ and tissue/
// need.
#pragma once

#include <itkImage.h>

#include <cstdint>
#include <filesystem>
#include <functional>
#include <string>

#include "tsf/import/import_report.h"

namespace tsf::import {

using HuImage = itk::Image<float, 3>;  ///< Hounsfield units, LPS physical geometry

struct ImportOptions {
  /// SeriesInstanceUID to import; empty = the only usable series (an error lists them if
  /// several are usable).
  std::string series_uid;
  /// Refuse a series that would need resampling (uneven spacing, missing slices, gantry tilt)
  /// instead of resampling it.
  bool strict = false;
  /// Progress bars on stderr when it is a terminal.
  bool show_progress = true;
  /// Output spacing along the stack when resampling (mm); 0 = the most frequent slice gap.
  double resampled_slice_spacing_mm = 0;
  /// Accept modalities other than CT (values stay in the modality's units, not HU).
  bool allow_non_ct = false;
  /// Refuse volumes with more voxels than this before allocating anything for them.
  std::int64_t max_voxels = std::int64_t{1} << 30;
  /// Threads decoding uncompressed DICOM files in parallel, and decoder processes running the
  /// codecs of compressed ones; 0 = OpenMP's default (the cores).
  int reader_threads = 0;
  /// Polled between files and while decoder processes run: returning true stops the import
  /// with tsf::Error("interrupted") (e.g. after Ctrl-C).
  std::function<bool()> stop_requested;
};

struct ImportResult {
  HuImage::Pointer image;
  ImportReport report;  ///< becomes the JSON sidecar (import_report_json.h)
};

/// Throws tsf::Error with a message naming the file, series, field or value and what was
/// expected. Never returns a half-imported volume.
ImportResult import_volume(const std::filesystem::path& path, const ImportOptions& options);

}  // namespace tsf::import
