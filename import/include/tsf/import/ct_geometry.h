// The geometry of a CT without its voxels, for `tsf info` and for `tsf run`'s check before it
// segments: dimensions, spacing, origin and direction of the volume import_volume would return,
// read from the file header (NRRD, MetaImage, NIfTI) or the DICOM headers (the catalog, no pixel
// decoding), plus helpers that describe that geometry: the extent of the voxel centres in the
// patient frame (LPS, mm), the same in tissue space (what scenes' crops and tools use), and the
// orientation as a three-letter code.
#pragma once

#include <array>
#include <filesystem>
#include <string>
#include <vector>

#include "tsf/common/vec3.h"
#include "tsf/import/dicom_catalog.h"
#include "tsf/import/import_volume.h"

namespace tsf::import {

struct CtGeometry {
  std::string kind;                 ///< "dicom", "nrrd", "metaimage" or "nifti"
  std::string series_instance_uid;  ///< DICOM: the series it describes
  Int3 dims;                        ///< voxels of the imported volume (after any resampling)
  Vec3d spacing;                    ///< mm
  Vec3d origin;                     ///< centre of voxel (0,0,0), mm, LPS
  std::array<double, 9> direction{1, 0, 0, 0, 1, 0, 0, 0, 1};  ///< row-major, columns = axes
  /// false when the file records no patient frame (an NRRD without `space` or `space
  /// directions`): the axes are then taken as L, P, S and the origin as 0, left/right unknown.
  bool orientation_recorded = true;
  bool resampled = false;  ///< DICOM: the import resamples the stack (tilt, uneven spacing)
};

/// An axis-aligned box, mm.
struct Box3 {
  Vec3d lo, hi;
  bool intersects(const Box3& o) const {
    return lo.x <= o.hi.x && o.lo.x <= hi.x && lo.y <= o.hi.y && o.lo.y <= hi.y && lo.z <= o.hi.z &&
           o.lo.z <= hi.z;
  }
  Box3 grown(double margin) const {
    return {lo - Vec3d{margin, margin, margin}, hi + Vec3d{margin, margin, margin}};
  }
  /// Distance from `p` to the box (0 inside), mm.
  double distance(const Vec3d& p) const;
};

/// The series `options.series_uid` names, or the only usable one. Throws tsf::Error as
/// import_volume does: an unknown UID (listing the series), several usable series and no UID
/// (listing them; "choose one with --series UID"), no usable series (with each one's problems).
const DicomSeries& select_dicom_series(const DicomCatalog& catalog, const ImportOptions& options);

/// The imported grid of a usable DICOM series (its geometry's output grid).
CtGeometry dicom_series_geometry(const DicomSeries& series);

/// From the file header only (inspect_volume_file).
CtGeometry volume_file_geometry(const std::filesystem::path& path, std::int64_t max_voxels);

/// Bounding box of the voxel centres in the patient frame (LPS, mm): the eight corner centres
/// through the direction matrix.
Box3 patient_extent(const CtGeometry& g);

/// Bounding box of the voxel centres in tissue space: origin + index × spacing, the direction
/// not applied (tsf::VolumeGeometry::index_to_tissue). Scenes place crops, anchors and tools in
/// this frame; it equals patient_extent when the direction is the identity.
Box3 tissue_extent(const CtGeometry& g);

bool identity_direction(const std::array<double, 9>& direction);

/// "LPS", "RAI", ...: for each voxel axis i, j, k the patient direction it points toward (L/R,
/// P/A, S/I) by its largest component. DICOM and ITK (LPS) convention: the identity is "LPS".
std::string orientation_code(const std::array<double, 9>& direction);

/// Largest angle, in degrees, between a voxel axis and the patient axis its code names (0 for an
/// axis-aligned volume; a tilted or oblique acquisition shows here).
double obliquity_deg(const std::array<double, 9>& direction);

}  // namespace tsf::import
