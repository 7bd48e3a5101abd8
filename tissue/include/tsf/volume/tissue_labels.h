// Tissue label values stored per voxel (uint8) and per lattice node.
//
// Ranges are reserved so that every module agrees on what a value means:
//   0            outside the tissue (air, background)
//   1 ..  63     tissue classes that make up the simulated body
//   64 .. 127    overlays (vessels, nerves, …): tissue whose exposure can trigger events
//   128 .. 254   user-defined (scene files may name them)
//   255          invalid / unset
#pragma once

#include <cstdint>
#include <string>

#include "tsf/common/hd.h"

namespace tsf {

enum TissueLabel : std::uint8_t {
  kLabelOutside = 0,
  kLabelSoftTissue = 1,  ///< generic soft tissue (muscle, skin, connective)
  kLabelMucosa = 2,      ///< mucosa lining the air spaces
  kLabelFat = 3,
  kLabelCartilage = 4,
  kLabelCancellousBone = 5,
  kLabelCorticalBone = 6,
  kLabelTumour = 7,
  kLabelFirstOverlay = 64,
  kLabelVessel = 64,
  kLabelNerve = 65,
  kLabelFirstUser = 128,
  kLabelInvalid = 255,
};

TSF_HD_INLINE bool is_tissue_label(std::uint8_t l) {
  return l >= 1 && l < kLabelFirstOverlay;
}
TSF_HD_INLINE bool is_overlay_label(std::uint8_t l) {
  return l >= kLabelFirstOverlay && l < kLabelFirstUser;
}
TSF_HD_INLINE bool is_bone_label(std::uint8_t l) {
  return l == kLabelCancellousBone || l == kLabelCorticalBone;
}

/// Human-readable name ("soft-tissue", "cortical-bone", "vessel"; "overlay", "user" or "tissue"
/// for labels without a name of their own).
const char* tissue_label_name(std::uint8_t label);
/// A unique name for reports and keys: the label's own name, else "label-<n>" ("label-130").
std::string tissue_label_key(std::uint8_t label);

}  // namespace tsf
