#include "tsf/haptics/device_frame.h"

#include <cmath>

namespace tsf::haptics {
namespace {

/// Row-major 3×3 rotation matrix of a unit quaternion.
void to_matrix(const Rotation& q, double m[9]) {
  const Vec3d x = q.apply({1, 0, 0}), y = q.apply({0, 1, 0}), z = q.apply({0, 0, 1});
  for (int r = 0; r < 3; ++r) {
    m[3 * r] = x[r];
    m[3 * r + 1] = y[r];
    m[3 * r + 2] = z[r];
  }
}

/// The unit quaternion of a row-major rotation matrix (Shepperd's method).
Rotation from_matrix(const double m[9]) {
  const double trace = m[0] + m[4] + m[8];
  Rotation q;
  if (trace > 0) {
    const double s = 2.0 * std::sqrt(1.0 + trace);
    q = {0.25 * s, (m[7] - m[5]) / s, (m[2] - m[6]) / s, (m[3] - m[1]) / s};
  } else if (m[0] > m[4] && m[0] > m[8]) {
    const double s = 2.0 * std::sqrt(1.0 + m[0] - m[4] - m[8]);
    q = {(m[7] - m[5]) / s, 0.25 * s, (m[1] + m[3]) / s, (m[2] + m[6]) / s};
  } else if (m[4] > m[8]) {
    const double s = 2.0 * std::sqrt(1.0 + m[4] - m[0] - m[8]);
    q = {(m[2] - m[6]) / s, (m[1] + m[3]) / s, 0.25 * s, (m[5] + m[7]) / s};
  } else {
    const double s = 2.0 * std::sqrt(1.0 + m[8] - m[0] - m[4]);
    q = {(m[3] - m[1]) / s, (m[2] + m[6]) / s, (m[5] + m[7]) / s, 0.25 * s};
  }
  return q.normalized();
}

/// M·R where M is the (orthonormal) matrix taking one frame's vectors to the other's; the tool's
/// local z is flipped when M mirrors, so the result stays a rotation.
Rotation turn(const std::array<double, 9>& M, bool transpose, bool mirrors, const Rotation& r) {
  double R[9], out[9];
  to_matrix(r, R);
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) {
      double s = 0;
      for (int k = 0; k < 3; ++k) s += (transpose ? M[3 * k + i] : M[3 * i + k]) * R[3 * k + j];
      out[3 * i + j] = s;
    }
  if (mirrors)
    for (int i = 0; i < 3; ++i) out[3 * i + 2] = -out[3 * i + 2];
  return from_matrix(out);
}

}  // namespace

ToolPose DeviceFrame::to_tissue(const ToolPose& p) const {
  if (!set_) return p;
  return {frame_.index_to_tissue(frame_.physical_to_index(p.position)),
          turn(frame_.direction, true, frame_.mirrors(), p.orientation)};
}

ToolPose DeviceFrame::to_patient(const ToolPose& t) const {
  if (!set_) return t;
  return {frame_.tissue_to_patient(t.position),
          turn(frame_.direction, false, frame_.mirrors(), t.orientation)};
}

}  // namespace tsf::haptics
