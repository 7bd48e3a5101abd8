#include "tsf/export/output_frame.h"

#include <cmath>
#include <cstdio>
#include <limits>

#include "tsf/common/error.h"

namespace tsf::exporter {

namespace {

using Mat3 = std::array<double, 9>;

Mat3 multiply(const Mat3& a, const Mat3& b) {
  Mat3 c{};
  for (int r = 0; r < 3; ++r)
    for (int k = 0; k < 3; ++k) {
      double s = 0;
      for (int j = 0; j < 3; ++j) s += a[r * 3 + j] * b[j * 3 + k];
      c[r * 3 + k] = s;
    }
  return c;
}

double determinant(const Mat3& m) {
  return m[0] * (m[4] * m[8] - m[5] * m[7]) - m[1] * (m[3] * m[8] - m[5] * m[6]) +
         m[2] * (m[3] * m[7] - m[4] * m[6]);
}

/// (m^-1)^T = cofactor matrix / det.
Mat3 inverse_transpose(const Mat3& m, double det) {
  Mat3 c{};
  c[0] = m[4] * m[8] - m[5] * m[7];
  c[1] = m[5] * m[6] - m[3] * m[8];
  c[2] = m[3] * m[7] - m[4] * m[6];
  c[3] = m[2] * m[7] - m[1] * m[8];
  c[4] = m[0] * m[8] - m[2] * m[6];
  c[5] = m[1] * m[6] - m[0] * m[7];
  c[6] = m[1] * m[5] - m[2] * m[4];
  c[7] = m[2] * m[3] - m[0] * m[5];
  c[8] = m[0] * m[4] - m[1] * m[3];
  for (double& v : c) v /= det;
  return c;
}

Vec3d transform(const Mat3& m, const Vec3d& v) {
  return {m[0] * v.x + m[1] * v.y + m[2] * v.z, m[3] * v.x + m[4] * v.y + m[5] * v.z,
          m[6] * v.x + m[7] * v.y + m[8] * v.z};
}

Mat3 axis_rotation(AxisConvention axes) {
  switch (axes) {
    case AxisConvention::y_up:
      return {1, 0, 0, 0, 0, 1, 0, -1, 0};
    case AxisConvention::lps:
      return {1, 0, 0, 0, 1, 0, 0, 0, 1};
    case AxisConvention::ras:
      return {-1, 0, 0, 0, -1, 0, 0, 0, 1};
  }
  return {1, 0, 0, 0, 1, 0, 0, 0, 1};
}

double unit_scale(LengthUnit units) {
  return units == LengthUnit::metre ? 0.001 : 1.0;
}

}  // namespace

Vec3d OutputFrame::position(const Vec3f& p) const {
  return transform(linear, to_double(p)) + translation;
}

Vec3f OutputFrame::normal(const Vec3f& n) const {
  const Vec3d m = transform(normal_linear, to_double(n));
  const double len = length(m);
  if (!(len > 0.0)) return {0, 0, 0};
  return to_float(m / len);
}

std::string OutputFrame::describe() const {
  const char* axes_text = axes == AxisConvention::y_up  ? "x=left y=superior z=anterior"
                          : axes == AxisConvention::lps ? "x=left y=posterior z=superior"
                                                        : "x=right y=anterior z=superior";
  char buf[256];
  std::snprintf(
      buf, sizeof(buf),
      "units %s, axes %s (%s, patient frame from the CT), centre offset %.3f %.3f %.3f mm",
      unit_name(units), axes_name(axes), axes_text, centre_offset.x, centre_offset.y,
      centre_offset.z);
  return buf;
}

std::array<double, 16> OutputFrame::matrix() const {
  return {linear[0], linear[1], linear[2], translation.x,
          linear[3], linear[4], linear[5], translation.y,
          linear[6], linear[7], linear[8], translation.z,
          0,         0,         0,         1};
}

OutputFrame make_output_frame(const VolumeGeometry& geometry, AxisConvention axes,
                              LengthUnit units) {
  const Mat3& d = geometry.direction;
  for (double v : d) require(std::isfinite(v), "volume direction matrix has a non-finite entry");
  const double det_d = determinant(d);
  require(std::fabs(det_d) > 1e-9,
          "volume direction matrix is singular (determinant " + std::to_string(det_d) + ")");
  const Mat3 a = axis_rotation(axes);
  const Mat3 ad = multiply(a, d);
  const double s = unit_scale(units);
  OutputFrame f;
  f.units = units;
  f.axes = axes;
  f.flips_winding = det_d < 0.0;
  f.normal_linear = inverse_transpose(ad, determinant(ad));
  for (int i = 0; i < 9; ++i)
    f.linear[static_cast<std::size_t>(i)] = s * ad[static_cast<std::size_t>(i)];
  // r = s·A·(origin + D·(p − origin)) = s·A·D·p + s·A·(origin − D·origin)
  const Vec3d o = geometry.origin;
  f.translation = transform(a, o - transform(d, o)) * s;
  return f;
}

OutputFrame centred_on(const OutputFrame& frame, const imt::SurfaceMesh& mesh) {
  OutputFrame f = frame;
  if (mesh.positions.empty()) return f;
  const double inf = std::numeric_limits<double>::infinity();
  Vec3d lo{inf, inf, inf}, hi{-inf, -inf, -inf};
  for (const Vec3f& p : mesh.positions) {
    const Vec3d r = frame.position(p);
    lo = {std::min(lo.x, r.x), std::min(lo.y, r.y), std::min(lo.z, r.z)};
    hi = {std::max(hi.x, r.x), std::max(hi.y, r.y), std::max(hi.z, r.z)};
  }
  const Vec3d c = (lo + hi) * 0.5;
  f.translation -= c;
  f.centre_offset = frame.centre_offset + c / unit_scale(frame.units);
  return f;
}

imt::SurfaceMesh to_output_frame(const imt::SurfaceMesh& mesh, const OutputFrame& frame) {
  imt::SurfaceMesh out;
  out.positions.resize(mesh.positions.size());
  out.normals.resize(mesh.normals.size());
  out.labels = mesh.labels;
  out.triangles = mesh.triangles;
  const auto n = static_cast<std::ptrdiff_t>(mesh.positions.size());
#pragma omp parallel for schedule(static)
  for (std::ptrdiff_t v = 0; v < n; ++v) {
    const auto i = static_cast<std::size_t>(v);
    out.positions[i] = to_float(frame.position(mesh.positions[i]));
    if (!mesh.normals.empty()) out.normals[i] = frame.normal(mesh.normals[i]);
  }
  if (frame.flips_winding)
    for (auto& t : out.triangles) std::swap(t[1], t[2]);
  return out;
}

}  // namespace tsf::exporter
