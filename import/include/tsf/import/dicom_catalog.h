// Discovery of DICOM image series under a path: a folder (walked recursively), a DICOMDIR, or a
// single file. Files are grouped by SeriesInstanceUID; each series is checked for being one
// volume (same size, orientation, pixel spacing and frame of reference; unique SOP instances;
// distinct positions) and its slice geometry is analysed from the headers alone, so a listing
// costs no pixel decoding.
#pragma once

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "tsf/import/dicom_file_info.h"
#include "tsf/import/slice_stack_geometry.h"

namespace tsf::import {

/// A file that is not part of any volume, and why.
struct SkippedFile {
  std::filesystem::path path;
  std::string reason;
  /// For a damaged file, the series it belongs to when that much could be read: the series is
  /// then refused (a volume silently missing a slice would be wrong).
  std::string series_instance_uid;
};

/// One slice of a series: frame `frame` of file `file` (index into DicomSeries::files).
struct DicomSliceRef {
  int file = 0;
  int frame = 0;
};

struct DicomSeries {
  std::string series_instance_uid;
  std::string modality, description, series_number;
  std::vector<DicomFileInfo> files;   ///< image files of the series, path order
  std::vector<DicomSliceRef> slices;  ///< every frame of every file, in file order
  /// Why the series is not one volume (non-empty = refused). Each names files and values.
  std::vector<std::string> problems;
  /// Geometry from the headers when the series is one volume.
  std::optional<SliceStackGeometry> geometry;

  bool usable() const { return problems.empty() && geometry.has_value(); }
  int image_count() const { return static_cast<int>(files.size()); }
  int slice_count() const { return static_cast<int>(slices.size()); }
};

struct DicomCatalog {
  std::filesystem::path root;  ///< what was scanned
  std::string discovered_by;   ///< "folder", "DICOMDIR" or "file"
  int files_examined = 0;
  std::vector<DicomSeries> series;  ///< sorted by series number, then UID
  std::vector<SkippedFile> skipped;
  double seconds = 0;

  std::vector<const DicomSeries*> usable_series() const;
  const DicomSeries* find(const std::string& series_uid) const;
};

struct CatalogOptions {
  SliceStackOptions geometry;
  bool show_progress = true;  ///< progress bar on a terminal while headers are read
};

/// Scans `path`. Throws tsf::Error only when `path` itself cannot be read (missing, a DICOMDIR
/// that cannot be parsed); problems with individual files go to `skipped` or a series' problems.
DicomCatalog catalog_dicom(const std::filesystem::path& path, const CatalogOptions& options = {});

/// Checks one group of same-series files and analyses its geometry (used by catalog_dicom).
void analyze_series(DicomSeries& series, const std::filesystem::path& root,
                    const SliceStackOptions& options);

/// One line for lists and error messages: UID, modality, number, description, images, size,
/// and "usable" or the first problem.
std::string one_line_summary(const DicomSeries& series);

/// `path` relative to `root` when it lies under it (for messages), else `path` unchanged.
std::string display_path(const std::filesystem::path& path, const std::filesystem::path& root);

}  // namespace tsf::import
