// The per-voxel rule that turns smoothed HU into a tissue class (tsf/volume/tissue_labels.h).
//
// What CT numbers can honestly separate (head, non-contrast CT):
//   air          <  -400 HU    outside the tissue (density < 0.5 decides; sinuses included)
//   fat          -190 .. -30   subcutaneous and orbital fat
//   soft tissue  -30 .. ~150   skin, muscle, brain, CSF, blood, mucosa, cartilage (all overlap)
//   bone         >= ~200       by hysteresis; cortical (dense, >= ~1000) vs cancellous (diploë)
// Mucosa and cartilage sit inside the soft-tissue range: mucosa gets a geometric label later
// (soft tissue lining an air space); cartilage needs a seeded region.
#pragma once

#include <cstdint>

#include "tsf/volume/tissue_labels.h"

namespace tsf::segment {

struct TissueClassRule {
  bool bone_enabled = true;
  float cortical_hu = 1000.0f;
  bool fat_enabled = true;
  float fat_min_hu = -190.0f;
  float fat_max_hu = -30.0f;
};

/// `density` decides inside/outside (>= 0.5 is tissue); `in_bone` is the hysteresis bone mask.
inline std::uint8_t classify_tissue_voxel(float hu, float density, bool in_bone,
                                          const TissueClassRule& rule) {
  if (!(density >= 0.5f)) return kLabelOutside;
  if (rule.bone_enabled && in_bone)
    return hu >= rule.cortical_hu ? kLabelCorticalBone : kLabelCancellousBone;
  if (rule.fat_enabled && hu >= rule.fat_min_hu && hu <= rule.fat_max_hu) return kLabelFat;
  return kLabelSoftTissue;
}

}  // namespace tsf::segment
