#include "tsf/import/slice_stack_geometry.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numeric>

#include "tsf/common/error.h"
#include "tsf/common/text_format.h"

namespace tsf::import {
namespace {

constexpr double kPi = 3.14159265358979323846;
/// Slices closer than this along the normal are at the same position (mm).
constexpr double kDuplicateToleranceMm = 0.01;
/// Largest number of voxels along one axis of a computed grid: far above any scanner, low enough
/// that garbage positions fail here with a message instead of overflowing an int.
constexpr double kMaxVoxelsPerAxis = 65536;

double median_of(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  const std::size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

int checked_count(double extent_mm, double spacing_mm, const char* axis, bool round_to_nearest) {
  const double steps = extent_mm / spacing_mm;
  if (!std::isfinite(steps) || steps + 1 > kMaxVoxelsPerAxis)
    throw Error(std::string("slice positions describe a grid of ") +
                format_text("%.4g", steps + 1) + " voxels along " + axis + " (extent " +
                format_text("%.6g", extent_mm) + " mm at " + format_text("%.4g", spacing_mm) +
                " mm spacing); expected at most 65536: the positions are not one volume");
  const double n = round_to_nearest ? std::round(steps) : std::ceil(steps - 1e-6);
  return static_cast<int>(n) + 1;
}

void require_finite(const Vec3d& v, const char* what) {
  if (!std::isfinite(v.x) || !std::isfinite(v.y) || !std::isfinite(v.z))
    throw Error(std::string(what) + " has a non-finite value");
}

}  // namespace

std::string describe_gap_runs(const std::vector<SliceGapRun>& runs) {
  std::string out;
  for (const auto& r : runs) {
    if (!out.empty()) out += ", ";
    out += format_text("%.2f", r.gap_mm) + " mm ×" + std::to_string(r.count);
  }
  return out;
}

SliceStackGeometry analyze_slice_stack(const std::vector<Vec3d>& positions, const PlaneAxes& axes,
                                       double spacing_x, double spacing_y, int columns, int rows,
                                       const SliceStackOptions& options) {
  const int m = static_cast<int>(positions.size());
  if (m < 2)
    throw Error("a volume needs at least 2 slices, got " + std::to_string(m) +
                " (a single image has no slice spacing: import the whole series folder)");
  if (!(spacing_x > 0) || !(spacing_y > 0) || !std::isfinite(spacing_x) ||
      !std::isfinite(spacing_y))
    throw Error("pixel spacing " + format_text("%g", spacing_y) + "\\" +
                format_text("%g", spacing_x) + " mm is not positive and finite");
  if (columns <= 0 || rows <= 0)
    throw Error("image size " + std::to_string(columns) + "×" + std::to_string(rows) + " is empty");
  for (const auto& p : positions) require_finite(p, "ImagePositionPatient");
  require_finite(axes.row, "ImageOrientationPatient (row)");
  require_finite(axes.column, "ImageOrientationPatient (column)");

  SliceStackGeometry g;
  g.spacing_x = spacing_x;
  g.spacing_y = spacing_y;
  g.columns = columns;
  g.rows = rows;

  // Orthonormalise the plane axes: IOP is stored as decimal strings, so it is only nearly unit
  // and nearly orthogonal; beyond 0.1° it is broken.
  const Vec3d row = normalized_or_zero(axes.row);
  Vec3d column = normalized_or_zero(axes.column);
  if (length(row) < 0.5 || length(column) < 0.5)
    throw Error("ImageOrientationPatient has a zero-length row or column vector");
  const double row_dot_column = dot(row, column);
  if (std::abs(row_dot_column) > std::sin(0.1 * kPi / 180))
    throw Error("ImageOrientationPatient row and column are not orthogonal (angle " +
                format_text("%.3f", std::acos(std::clamp(row_dot_column, -1.0, 1.0)) * 180 / kPi) +
                "°)");
  column = normalized_or_zero(column - row * row_dot_column);
  g.axes = {row, column};
  g.normal = cross(row, column);
  const Vec3d& n = g.normal;

  // Sort by offset along the normal.
  std::vector<double> t(m);
  for (int i = 0; i < m; ++i) t[i] = dot(positions[i], n);
  g.sorted.resize(m);
  std::iota(g.sorted.begin(), g.sorted.end(), 0);
  std::stable_sort(g.sorted.begin(), g.sorted.end(), [&](int a, int b) { return t[a] < t[b]; });
  for (int k = 0; k < m; ++k) {
    g.sorted_positions.push_back(positions[g.sorted[k]]);
    g.offsets_mm.push_back(t[g.sorted[k]] - t[g.sorted[0]]);
  }

  // Duplicates: runs of slices within the tolerance of the run's first slice.
  for (int k = 0; k < m;) {
    int e = k + 1;
    while (e < m && g.offsets_mm[e] - g.offsets_mm[k] < kDuplicateToleranceMm) ++e;
    if (e - k > 1) {
      DuplicatePosition d;
      d.offset_mm = t[g.sorted[k]];
      for (int q = k; q < e; ++q) d.slices.push_back(g.sorted[q]);
      g.duplicates.push_back(std::move(d));
    }
    k = e;
  }
  if (!g.duplicates.empty()) return g;  // not one volume; the caller refuses it

  for (int k = 0; k + 1 < m; ++k) g.gaps_mm.push_back(g.offsets_mm[k + 1] - g.offsets_mm[k]);
  g.median_gap_mm = median_of(g.gaps_mm);
  const double tol =
      std::max(options.even_gap_tolerance_mm, options.even_gap_tolerance_rel * g.median_gap_mm);
  // The regular gap: the most frequent gap (clusters of gaps within the tolerance), the smaller
  // one on a tie, so a series of 4 mm then 7 mm slices keeps its 4 mm detail.
  {
    std::vector<double> sorted_gaps = g.gaps_mm;
    std::sort(sorted_gaps.begin(), sorted_gaps.end());
    std::size_t best_count = 0;
    for (std::size_t b = 0; b < sorted_gaps.size();) {
      std::size_t e = b;
      double sum = 0;
      while (e < sorted_gaps.size() && sorted_gaps[e] - sorted_gaps[b] <= tol)
        sum += sorted_gaps[e++];
      if (e - b > best_count) {
        best_count = e - b;
        g.regular_gap_mm = sum / static_cast<double>(e - b);
      }
      b = e;
    }
  }
  const double widest = *std::max_element(g.gaps_mm.begin(), g.gaps_mm.end());
  if (widest > options.max_gap_factor * g.regular_gap_mm)
    throw Error("a gap of " + format_text("%.2f", widest) + " mm between slices is " +
                format_text("%.0f", widest / g.regular_gap_mm) + "× the regular gap of " +
                format_text("%.2f", g.regular_gap_mm) +
                " mm: the series holds separate stacks, not one volume");
  for (double gap : g.gaps_mm)
    if (std::abs(gap - g.median_gap_mm) > tol) g.uneven = true;
  std::vector<int> run_length(g.gaps_mm.size(), 1);
  for (std::size_t k = 0; k < g.gaps_mm.size();) {
    std::size_t e = k + 1;
    double sum = g.gaps_mm[k];
    while (e < g.gaps_mm.size() && std::abs(g.gaps_mm[e] - g.gaps_mm[k]) <= tol)
      sum += g.gaps_mm[e++];
    g.gap_runs.push_back({sum / static_cast<double>(e - k), static_cast<int>(e - k)});
    for (std::size_t q = k; q < e; ++q) run_length[q] = static_cast<int>(e - k);
    k = e;
  }
  // Missing slices: an isolated gap (a run of at most two) that is close to a whole multiple
  // (≥ 2) of the regular gap. A long run of wider gaps is a protocol change, not a loss.
  for (std::size_t k = 0; k < g.gaps_mm.size(); ++k) {
    const double ratio = g.gaps_mm[k] / g.regular_gap_mm;
    const long multiple = std::lround(ratio);
    if (multiple >= 2 &&
        std::abs(ratio - static_cast<double>(multiple)) <= options.missing_gap_multiple_tolerance &&
        run_length[k] <= 2)
      g.missing.push_back({static_cast<int>(k), g.gaps_mm[k], static_cast<int>(multiple - 1)});
  }

  // Tilt: the in-plane drift of each slice position relative to the first.
  const Vec3d p0 = g.sorted_positions.front();
  for (int k = 0; k < m; ++k) {
    const Vec3d dp = g.sorted_positions[k] - p0;
    const Vec3d drift = dp - n * dot(dp, n);
    g.max_drift_mm = std::max(g.max_drift_mm, length(drift));
  }
  g.stack_direction = normalized_or_zero(g.sorted_positions.back() - p0);
  g.tilt_deg = std::acos(std::clamp(dot(g.stack_direction, n), -1.0, 1.0)) * 180 / kPi;
  g.tilted = g.max_drift_mm > options.tilt_drift_tolerance_px * std::min(spacing_x, spacing_y);

  if (g.tilted)
    g.resampling_reasons.push_back("gantry tilt " + format_text("%.2f", g.tilt_deg) + "°");
  if (g.uneven)
    g.resampling_reasons.push_back("uneven slice spacing (" + describe_gap_runs(g.gap_runs) + ")");
  g.needs_resampling = g.tilted || g.uneven;

  const double span_n = g.offsets_mm.back();
  OrthogonalGrid& grid = g.grid;
  if (!g.tilted) {
    grid.axes = {row, column, n};
    grid.origin = p0;
    grid.dims.x = columns;
    grid.dims.y = rows;
    double target = g.needs_resampling && options.resampled_slice_spacing_mm > 0
                        ? options.resampled_slice_spacing_mm
                        : g.regular_gap_mm;
    if (!g.needs_resampling) target = span_n / (m - 1);
    grid.dims.z = std::max(2, checked_count(span_n, target, "the slice normal", true));
    grid.spacing = {spacing_x, spacing_y, span_n / (grid.dims.z - 1)};
    return g;
  }

  // Tilted: an orthogonal grid whose z axis is the table (stacking) axis and whose x axis is the
  // image row direction made perpendicular to it. For the usual tilt about the row axis this is
  // the patient's axial frame: slices become perpendicular to the long axis and in-plane pixels
  // keep their spacing.
  const Vec3d z_axis = g.stack_direction;
  const Vec3d x_raw = row - z_axis * dot(row, z_axis);
  if (length(x_raw) < 0.1)
    throw Error("slices are stacked along their own row direction (tilt " +
                format_text("%.1f", g.tilt_deg) + "°): not a tomographic volume");
  const Vec3d x_axis = normalized_or_zero(x_raw);
  const Vec3d y_axis = cross(z_axis, x_axis);
  grid.axes = {x_axis, y_axis, z_axis};

  Vec3d lo{1e300, 1e300, 1e300}, hi{-1e300, -1e300, -1e300};
  const double ex = (columns - 1) * spacing_x, ey = (rows - 1) * spacing_y;
  for (const Vec3d& p : g.sorted_positions)
    for (int c = 0; c < 4; ++c) {
      const Vec3d corner = p + row * (c & 1 ? ex : 0.0) + column * (c & 2 ? ey : 0.0) - p0;
      for (int a = 0; a < 3; ++a) {
        const double v = dot(corner, grid.axes[a]);
        lo[a] = std::min(lo[a], v);
        hi[a] = std::max(hi[a], v);
      }
    }
  // Regular gap measured along the table axis (what the table moved between slices).
  const double table_gap = g.regular_gap_mm / std::max(1e-6, dot(z_axis, n));
  const double target_z =
      options.resampled_slice_spacing_mm > 0 ? options.resampled_slice_spacing_mm : table_gap;
  grid.dims.x = checked_count(hi.x - lo.x, spacing_x, "x", false);
  grid.dims.y = checked_count(hi.y - lo.y, spacing_y, "y", false);
  grid.dims.z = std::max(2, checked_count(hi.z - lo.z, target_z, "the table axis", true));
  grid.spacing = {spacing_x, spacing_y, (hi.z - lo.z) / (grid.dims.z - 1)};
  grid.origin = p0 + x_axis * lo.x + y_axis * lo.y + z_axis * lo.z;
  g.tilt_resolution =
      "resampled onto an orthogonal grid whose z axis is the table (stacking) axis: slices are "
      "perpendicular to the table, x follows the image rows, in-plane spacing is kept; values "
      "are trilinear between the two nearest acquired planes; the grid is the bounding box of "
      "all acquired pixels, voxels outside them hold the fill value";
  return g;
}

}  // namespace tsf::import
