#include "tsf/volume/tool_shapes.h"

namespace tsf {

Rotation Rotation::slerp(const Rotation& a, Rotation b, double t) {
  double c = a.w * b.w + a.x * b.x + a.y * b.y + a.z * b.z;
  if (c < 0.0) {  // q and -q are the same rotation: take the short arc
    b = {-b.w, -b.x, -b.y, -b.z};
    c = -c;
  }
  double wa = 1.0 - t, wb = t;
  if (c < 0.9995) {  // otherwise nearly parallel: linear blend then normalise
    const double theta = std::acos(c);
    const double s = std::sin(theta);
    wa = std::sin((1.0 - t) * theta) / s;
    wb = std::sin(t * theta) / s;
  }
  return Rotation{wa * a.w + wb * b.w, wa * a.x + wb * b.x, wa * a.y + wb * b.y,
                  wa * a.z + wb * b.z}
      .normalized();
}

}  // namespace tsf
