// Force magnitude from an intersection volume (thesis Eq. 12), shared by the voxel and mesh
// models:
//   F = (c1·V)^c2          while V < cutoff·V_stylus   (cutoff = ½: the thesis's valid range)
//   F = 0                  beyond it
// V in mm³, F in µN (c1 in µN^(1/c2)/mm³). The direction (stylus centre − intersection centroid)
// is only meaningful while the stylus is less than half immersed; past that the centroid nears the
// centre and the direction turns unreliable, so the force is masked (thesis Fig. 58).
//
// The hard mask is a kick: the force drops from its maximum to zero in one tick. `taper` (a
// fraction of the valid range, 0 = the thesis's hard cut-off) fades it out with a smoothstep over
// the last part of the range, so the magnitude rises and falls as two smooth peaks when the stylus
// passes through tissue (thesis Fig. 68). Per-evaluation math, TSF_HD.
#pragma once

#include <cmath>

#include "tsf/common/hd.h"

namespace tsf::haptics {

struct ForceLaw {
  double c1 = 1.0e4;             ///< µN^(1/c2) per mm³ (c2 = 1: 0.01 N per mm³ of overlap)
  double c2 = 1.0;               ///< shape: < 1 makes soft touches perceptible, > 1 avoids kicks
  double cutoff_fraction = 0.5;  ///< of the stylus volume, in (0, 1]
  double taper_fraction = 0.5;   ///< of the valid range faded out before the cut-off, in [0, 1)

  /// Throws tsf::Error naming the field when out of range.
  void validate() const;

  /// Magnitude for intersection volume V of a stylus of volume V_stylus (mm³), µN.
  TSF_HD_INLINE double magnitude(double V, double V_stylus) const {
    const double limit = cutoff_fraction * V_stylus;
    if (!(V > 0.0) || !(V < limit)) return 0.0;
    double f = pow(c1 * V, c2);
    if (taper_fraction > 0.0) {
      const double x = (1.0 - V / limit) / taper_fraction;  // 1 at the taper's start, 0 at cut-off
      if (x < 1.0) f *= x * x * (3.0 - 2.0 * x);
    }
    return f;
  }
};

}  // namespace tsf::haptics
