#include "tsf/import/slice_stack_resampler.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "tsf/common/error.h"

namespace tsf::import {
namespace {

/// Tolerance, in pixels, for a sample that falls just outside a plane (positions are decimal
/// strings, so a voxel meant to sit on the edge lands a hair beyond it).
constexpr double kEdge = 1e-3;

/// Nearest whole number (halves to even) without a branch or a library call, so loops using
/// it vectorise: adding and subtracting 1.5·2^23 drops the fraction. Exact for |v| ≤ 2^22,
/// which the caller guarantees (ResampleOptions::round_to_integer).
inline float round_to_whole(float v) {
  constexpr float kMagic = 12582912.0f;  // 1.5·2^23
  return (v + kMagic) - kMagic;
}

template <bool kRound>
inline float finish(float v) {
  if constexpr (kRound) return round_to_whole(v);
  return v;
}

/// Bilinear sample of one plane at pixel coordinates (u, v); false when (u, v) lies outside.
inline bool sample_plane(const float* plane, int columns, int rows, double u, double v,
                         float& value) {
  if (!(u >= -kEdge && v >= -kEdge && u <= columns - 1 + kEdge && v <= rows - 1 + kEdge))
    return false;
  u = std::clamp(u, 0.0, static_cast<double>(columns - 1));
  v = std::clamp(v, 0.0, static_cast<double>(rows - 1));
  const int i0 = std::min(static_cast<int>(u), std::max(columns - 2, 0));
  const int j0 = std::min(static_cast<int>(v), std::max(rows - 2, 0));
  const int i1 = std::min(i0 + 1, columns - 1);
  const int j1 = std::min(j0 + 1, rows - 1);
  const float fu = static_cast<float>(u - i0);
  const float fv = static_cast<float>(v - j0);
  const float* r0 = plane + static_cast<std::size_t>(j0) * columns;
  const float* r1 = plane + static_cast<std::size_t>(j1) * columns;
  const float top = r0[i0] + fu * (r0[i1] - r0[i0]);
  const float bottom = r1[i0] + fu * (r1[i1] - r1[i0]);
  value = top + fv * (bottom - top);
  return true;
}

/// The planes, with their offsets along the normal and in-plane coordinates of their positions.
struct Stack {
  const SliceStackSamples& in;
  std::vector<double> offset, pos_row, pos_col;
  std::size_t plane_size;
  double t_eps;

  /// Lower bracketing plane of offset t (starting the search at `m`) and the upper's weight.
  double bracket(double t, int& m) const {
    while (m > 0 && offset[m] > t) --m;
    while (m < in.slices - 2 && offset[m + 1] <= t) ++m;
    return std::clamp((t - offset[m]) / (offset[m + 1] - offset[m]), 0.0, 1.0);
  }
  bool inside(double t) const { return t >= -t_eps && t <= offset.back() + t_eps; }
  const float* plane(int m) const { return in.values + static_cast<std::size_t>(m) * plane_size; }
};

/// One bracketing plane's part of an aligned output row (t and v fixed, u = u0 + i).
struct PlaneRow {
  bool used = false;
  float weight = 0;
  const float* r0 = nullptr;  ///< image row j0 of the plane
  const float* r1 = nullptr;  ///< image row j0 + 1 (or j0 at the last row)
  float fu = 0, fv = 0;
  int iu0 = 0;              ///< image column of output i = 0 (may be negative)
  int i_lo = 0, i_hi = -1;  ///< output columns that fall inside the plane
};

/// One output row when the grid's x axis is the image row direction with the same spacing:
/// the two bracketing planes and their image rows are fixed, and the image column advances by
/// exactly one per voxel, so the interpolation weights are constant along the row.
template <bool kRound>
std::int64_t resample_aligned_row(const Stack& s, double t, double qr0, double qc0, float fill,
                                  float* out, int nx, int& m) {
  const SliceStackSamples& in = s.in;
  if (!s.inside(t)) {
    std::fill(out, out + nx, fill);
    return nx;
  }
  const double w = s.bracket(t, m);
  PlaneRow planes[2];
  int used = 0;
  for (int p = 0; p < 2; ++p) {
    const double weight = p == 0 ? 1 - w : w;
    if (weight <= 0) continue;
    const int mm = m + p;
    const double v = (qc0 - s.pos_col[mm]) / in.spacing_y;
    if (!(v >= -kEdge && v <= in.rows - 1 + kEdge)) continue;
    const double vc = std::clamp(v, 0.0, static_cast<double>(in.rows - 1));
    const int j0 = std::min(static_cast<int>(vc), std::max(in.rows - 2, 0));
    const double u0 = (qr0 - s.pos_row[mm]) / in.spacing_x;
    // Snap u0 to a whole column within the edge tolerance (decimal positions).
    const double u_round = std::round(u0);
    const double u_snap = std::abs(u0 - u_round) < kEdge ? u_round : u0;
    PlaneRow& pr = planes[used++];
    pr.used = true;
    pr.weight = static_cast<float>(weight);
    pr.r0 = s.plane(mm) + static_cast<std::size_t>(j0) * in.columns;
    pr.r1 = s.plane(mm) + static_cast<std::size_t>(std::min(j0 + 1, in.rows - 1)) * in.columns;
    pr.fv = static_cast<float>(vc - j0);
    pr.iu0 = static_cast<int>(std::floor(u_snap));
    pr.fu = static_cast<float>(u_snap - pr.iu0);
    pr.i_lo = std::max(0, static_cast<int>(std::ceil(-kEdge - u_snap)));
    pr.i_hi = std::min(nx - 1, static_cast<int>(std::floor(in.columns - 1 + kEdge - u_snap)));
  }
  auto bilinear = [&](const PlaneRow& pr, int i) {
    const int c0 = std::clamp(pr.iu0 + i, 0, in.columns - 1);
    const int c1 = std::min(c0 + 1, in.columns - 1);
    const float top = pr.r0[c0] + pr.fu * (pr.r0[c1] - pr.r0[c0]);
    const float bottom = pr.r1[c0] + pr.fu * (pr.r1[c1] - pr.r1[c0]);
    return top + pr.fv * (bottom - top);
  };

  // Fused path: the used planes cover the same output columns (always so without tilt about
  // the column axis): one pass, constant weights, unit stride.
  const bool same_range =
      used == 1 || (used == 2 && planes[0].i_lo == planes[1].i_lo &&
                    planes[0].i_hi == planes[1].i_hi && planes[0].iu0 == planes[1].iu0);
  const float wsum = used == 0 ? 0.0f : planes[0].weight + (used == 2 ? planes[1].weight : 0.0f);
  if (same_range && (used == 0 || wsum < 0.5f || planes[0].i_lo > planes[0].i_hi)) {
    std::fill(out, out + nx, fill);
    return nx;
  }
  if (same_range) {
    const PlaneRow& a = planes[0];
    const PlaneRow& b = planes[used == 2 ? 1 : 0];
    const float wa = a.weight / wsum, wb = used == 2 ? b.weight / wsum : 0.0f;
    std::fill(out, out + a.i_lo, fill);
    std::fill(out + a.i_hi + 1, out + nx, fill);
    // Columns c0 = iu0 + i and c0 + 1 both exist below i_full; the last column is clamped.
    const int i_full = std::max(a.i_lo, std::min(a.i_hi + 1, in.columns - 1 - a.iu0));
    const float *a0 = a.r0 + a.iu0, *a1 = a.r1 + a.iu0, *b0 = b.r0 + b.iu0, *b1 = b.r1 + b.iu0;
    const float afu = a.fu, afv = a.fv, bfu = b.fu, bfv = b.fv;
#pragma omp simd
    for (int i = a.i_lo; i < i_full; ++i) {
      const float at = a0[i] + afu * (a0[i + 1] - a0[i]);
      const float ab = a1[i] + afu * (a1[i + 1] - a1[i]);
      const float bt = b0[i] + bfu * (b0[i + 1] - b0[i]);
      const float bb = b1[i] + bfu * (b1[i + 1] - b1[i]);
      out[i] = finish<kRound>(wa * (at + afv * (ab - at)) + wb * (bt + bfv * (bb - bt)));
    }
    for (int i = i_full; i <= a.i_hi; ++i)
      out[i] = finish<kRound>(wa * bilinear(a, i) + (used == 2 ? wb * bilinear(b, i) : 0.0f));
    return static_cast<std::int64_t>(a.i_lo) + (nx - 1 - a.i_hi);
  }

  // Planes cover different columns (edges of a tilted stack): per voxel, normalised by the
  // weight of the planes that cover it.
  std::int64_t filled = 0;
  for (int i = 0; i < nx; ++i) {
    float acc = 0, weight = 0;
    for (int p = 0; p < used; ++p)
      if (i >= planes[p].i_lo && i <= planes[p].i_hi) {
        acc += planes[p].weight * bilinear(planes[p], i);
        weight += planes[p].weight;
      }
    if (weight >= 0.5f) {
      out[i] = finish<kRound>(acc / weight);
    } else {
      out[i] = fill;
      ++filled;
    }
  }
  return filled;
}

/// One output row in general position: t, u and v all vary along the row.
template <bool kRound>
std::int64_t resample_general_row(const Stack& s, const Vec3d& n, const Vec3d& q0, double dt,
                                  double dqr, double dqc, float fill, float* out, int nx, int& m) {
  const SliceStackSamples& in = s.in;
  const double t0 = dot(q0 - in.positions[0], n);
  const double qr0 = dot(q0, in.row), qc0 = dot(q0, in.column);
  std::int64_t filled = 0;
  for (int i = 0; i < nx; ++i) {
    const double t = t0 + i * dt;
    if (!s.inside(t)) {
      out[i] = fill;
      ++filled;
      continue;
    }
    const double w = s.bracket(t, m);
    const double qr = qr0 + i * dqr, qc = qc0 + i * dqc;
    double acc = 0, weight = 0;
    float sample;
    if (w < 1 && sample_plane(s.plane(m), in.columns, in.rows, (qr - s.pos_row[m]) / in.spacing_x,
                              (qc - s.pos_col[m]) / in.spacing_y, sample)) {
      acc += (1 - w) * static_cast<double>(sample);
      weight += 1 - w;
    }
    if (w > 0 &&
        sample_plane(s.plane(m + 1), in.columns, in.rows, (qr - s.pos_row[m + 1]) / in.spacing_x,
                     (qc - s.pos_col[m + 1]) / in.spacing_y, sample)) {
      acc += w * static_cast<double>(sample);
      weight += w;
    }
    if (weight >= 0.5) {
      out[i] = finish<kRound>(static_cast<float>(acc / weight));
    } else {
      out[i] = fill;
      ++filled;
    }
  }
  return filled;
}

template <bool kRound>
ResampleStatistics resample(const SliceStackSamples& in, const OrthogonalGrid& grid,
                            float fill_value, float* out, Progress* progress) {
  const Vec3d n = cross(in.row, in.column);
  Stack s{in,
          std::vector<double>(in.slices),
          std::vector<double>(in.slices),
          std::vector<double>(in.slices),
          static_cast<std::size_t>(in.columns) * in.rows,
          0};
  for (int m = 0; m < in.slices; ++m) {
    s.offset[m] = dot(in.positions[m] - in.positions[0], n);
    s.pos_row[m] = dot(in.positions[m], in.row);
    s.pos_col[m] = dot(in.positions[m], in.column);
    if (m > 0 && !(s.offset[m] > s.offset[m - 1]))
      throw Error("resample_slice_stack: slices are not sorted by strictly increasing offset");
  }
  s.t_eps = 1e-4 + 1e-9 * s.offset.back();
  const Vec3d step = grid.axes[0] * grid.spacing.x;
  const double dt = dot(step, n), dqr = dot(step, in.row), dqc = dot(step, in.column);
  const int nx = grid.dims.x, ny = grid.dims.y, nz = grid.dims.z;
  // The common case (no tilt about the column axis, in-plane spacing kept): along an output row
  // the plane offset and the in-plane v stay fixed and u advances by exactly one pixel.
  const bool aligned = std::abs(dt) * nx < 1e-9 && std::abs(dqc) * nx < 1e-9 &&
                       std::abs(dqr / in.spacing_x - 1) * nx < 1e-6;

  std::int64_t filled = 0, fractional = 0;
  float lo = std::numeric_limits<float>::infinity(), hi = -lo;
#pragma omp parallel for schedule(dynamic, 1) reduction(+ : filled, fractional) \
    reduction(min : lo) reduction(max : hi)
  for (int k = 0; k < nz; ++k) {
    int m = 0;
    for (int j = 0; j < ny; ++j) {
      const Vec3d q0 = grid.point(0, j, k);
      float* row_out = out + (static_cast<std::size_t>(k) * ny + j) * nx;
      if (aligned)
        filled += resample_aligned_row<kRound>(s, dot(q0 - in.positions[0], n), dot(q0, in.row),
                                               dot(q0, in.column), fill_value, row_out, nx, m);
      else
        filled += resample_general_row<kRound>(s, n, q0, dt, dqr, dqc, fill_value, row_out, nx, m);
      // Statistics of the row just written (still in cache): saves a pass over the volume.
      float row_lo = lo, row_hi = hi;
      int row_fractional = 0;
#pragma omp simd reduction(min : row_lo) reduction(max : row_hi) reduction(+ : row_fractional)
      for (int i = 0; i < nx; ++i) {
        const float v = row_out[i];
        row_lo = v < row_lo ? v : row_lo;
        row_hi = v > row_hi ? v : row_hi;
        if constexpr (!kRound) row_fractional += round_to_whole(v) != v;
      }
      lo = std::min(lo, row_lo);
      hi = std::max(hi, row_hi);
      fractional += row_fractional;
    }
    if (progress) progress->advance();
  }
  return {filled, lo, hi, fractional == 0};
}

}  // namespace

ResampleStatistics resample_slice_stack(const SliceStackSamples& in, const OrthogonalGrid& grid,
                                        const ResampleOptions& options, float* out,
                                        Progress* progress) {
  require(in.slices >= 2 && in.columns > 0 && in.rows > 0 && in.values && in.positions,
          "resample_slice_stack: need at least 2 non-empty slices");
  require(in.spacing_x > 0 && in.spacing_y > 0, "resample_slice_stack: spacing must be positive");
  return options.round_to_integer ? resample<true>(in, grid, options.fill_value, out, progress)
                                  : resample<false>(in, grid, options.fill_value, out, progress);
}

}  // namespace tsf::import
