// One haptic tick as recorded by the loop and the playback: what the stylus did and felt.
#pragma once

#include "tsf/common/vec3.h"

namespace tsf::haptics {

struct HapticSample {
  double time_s = 0;            ///< tick time, s
  Vec3d position_mm{0, 0, 0};   ///< stylus centre, deformed world
  Vec3d raw_force_un{0, 0, 0};  ///< the model's output, µN
  Vec3d force_un{0, 0, 0};      ///< after the filter and the device clamp: what is rendered
  double intersection_mm3 = 0;  ///< the model's intersection volume (0 for lattice)
  int contacts = 0;             ///< cells / spheres / nodes in contact
  double frame_age_s = 0;       ///< tick time − simulation time of the frame used
  float compute_us = 0;         ///< read + evaluate + filter + write, µs
};

}  // namespace tsf::haptics
