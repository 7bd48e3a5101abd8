// Geometry of a stack of parallel image planes (a DICOM series or the frames of an enhanced
// multi-frame object), taken from ImagePositionPatient and ImageOrientationPatient only.
//
// SliceThickness is never used: it is the reconstructed slab thickness, which differs from the
// distance between slice centres whenever slices overlap or leave gaps.
//
// Frames and units (all in the DICOM patient frame, LPS, mm):
//   row      unit vector along which the column index i grows (first 3 values of IOP)
//   column   unit vector along which the row index j grows (last 3 values of IOP)
//   normal   row × column; slices are sorted by their offset t = position·normal
//   pixel (i, j) of slice m lies at  position_m + i·spacing_x·row + j·spacing_y·column
//
// What the analysis finds, and what the importer does with it:
//   duplicate positions   two slices at the same t          -> refused (not one volume)
//   uneven spacing        gaps differ by more than a tolerance -> resampled (or refused, strict)
//   missing slices        an isolated gap ≈ k× the regular gap (k ≥ 2) -> reported, resampled
//   gantry tilt           slice positions drift in-plane,   -> resampled onto an orthogonal grid
//                         i.e. the stack is sheared            whose z axis is the table axis
#pragma once

#include <array>
#include <string>
#include <vector>

#include "tsf/common/vec3.h"

namespace tsf::import {

/// Orthonormal-or-not axes of an acquisition plane (unit vectors, LPS).
struct PlaneAxes {
  Vec3d row{1, 0, 0};
  Vec3d column{0, 1, 0};
  Vec3d normal() const { return cross(row, column); }
};

/// A regular, orthogonal voxel grid in patient space: voxel (i,j,k) lies at
/// origin + i·spacing.x·axes[0] + j·spacing.y·axes[1] + k·spacing.z·axes[2].
struct OrthogonalGrid {
  Int3 dims;               ///< voxels along i, j, k
  Vec3d spacing{1, 1, 1};  ///< mm
  Vec3d origin;            ///< centre of voxel (0,0,0), mm, LPS
  std::array<Vec3d, 3> axes{Vec3d{1, 0, 0}, Vec3d{0, 1, 0}, Vec3d{0, 0, 1}};  ///< unit, LPS
  Vec3d point(double i, double j, double k) const {
    return origin + axes[0] * (i * spacing.x) + axes[1] * (j * spacing.y) +
           axes[2] * (k * spacing.z);
  }
};

/// A run of equal consecutive gaps, e.g. {4.00 mm, 13}.
struct SliceGapRun {
  double gap_mm = 0;
  int count = 0;
};

/// A gap that is too wide for the regular spacing: slices are probably missing there.
struct MissingSlicesGap {
  int after_slice = 0;  ///< sorted slice index before the gap
  double gap_mm = 0;    ///< along the normal
  int estimated_missing = 0;
};

/// Two or more slices at the same offset along the normal.
struct DuplicatePosition {
  double offset_mm = 0;     ///< t, along the normal
  std::vector<int> slices;  ///< caller's slice indices (unsorted input order)
};

struct SliceStackOptions {
  /// Output spacing along the stack (mm) when the stack is resampled; 0 = choose automatically
  /// (the most frequent gap, the smaller on a tie: no detail is lost where slices are regular).
  double resampled_slice_spacing_mm = 0;
  /// Gaps are "even" when they all lie within max(abs, rel·median) of the median gap.
  double even_gap_tolerance_mm = 0.01;
  double even_gap_tolerance_rel = 0.01;
  /// In-plane drift of slice positions below this fraction of a pixel is not a tilt.
  double tilt_drift_tolerance_px = 0.05;
  /// An isolated gap within this distance of a whole multiple (≥ 2) of the regular gap is
  /// reported as missing slices (e.g. 10.1 mm in a 5 mm series: 1 missing).
  double missing_gap_multiple_tolerance = 0.15;
  /// A gap wider than this multiple of the regular gap splits the series into separate stacks:
  /// refused rather than interpolated across.
  double max_gap_factor = 10;
};

struct SliceStackGeometry {
  PlaneAxes axes;        ///< acquisition plane axes (orthonormalised)
  Vec3d normal;          ///< axes.normal()
  double spacing_x = 0;  ///< mm between columns (along row)
  double spacing_y = 0;  ///< mm between rows (along column)
  int columns = 0, rows = 0;

  std::vector<int> sorted;              ///< input slice indices sorted by offset along the normal
  std::vector<Vec3d> sorted_positions;  ///< positions in sorted order, mm
  std::vector<double> offsets_mm;       ///< t of each sorted slice relative to the first, mm
  std::vector<double> gaps_mm;          ///< consecutive gaps along the normal (size slices-1)
  std::vector<SliceGapRun> gap_runs;    ///< gaps_mm grouped into runs of equal gaps
  double median_gap_mm = 0;
  double regular_gap_mm = 0;  ///< smallest gap that is not an outlier (< ½ median)
  bool uneven = false;

  Vec3d stack_direction;    ///< unit vector from the first to the last slice position
  double tilt_deg = 0;      ///< angle between stack_direction and the normal
  double max_drift_mm = 0;  ///< largest in-plane offset of a slice position
  bool tilted = false;      ///< drift exceeds the tolerance: the stack is sheared

  std::vector<DuplicatePosition> duplicates;
  std::vector<MissingSlicesGap> missing;

  bool needs_resampling = false;                ///< tilted, uneven or with missing slices
  std::vector<std::string> resampling_reasons;  ///< e.g. "gantry tilt 18.5°"
  std::string tilt_resolution;                  ///< how the tilt was resolved (empty if none)
  /// Where the volume goes: the acquisition grid itself when no resampling is needed.
  OrthogonalGrid grid;

  int slice_count() const { return static_cast<int>(sorted.size()); }
};

/// Analyses slices of `columns`×`rows` pixels that share `axes` and pixel spacing, placed at
/// `positions` (ImagePositionPatient per slice, any order). Throws tsf::Error when the input
/// cannot describe a volume (fewer than 2 slices, degenerate axes, non-finite values). Duplicate
/// positions do not throw: they are returned in `duplicates` for the caller to refuse with
/// file names.
SliceStackGeometry analyze_slice_stack(const std::vector<Vec3d>& positions, const PlaneAxes& axes,
                                       double spacing_x, double spacing_y, int columns, int rows,
                                       const SliceStackOptions& options = {});

/// "4.00 mm ×13, 1.08 mm ×1, 7.00 mm ×13"
std::string describe_gap_runs(const std::vector<SliceGapRun>& runs);

}  // namespace tsf::import
