#include "tsf/volume/tissue_labels.h"

namespace tsf {

const char* tissue_label_name(std::uint8_t label) {
  switch (label) {
    case kLabelOutside:
      return "outside";
    case kLabelSoftTissue:
      return "soft-tissue";
    case kLabelMucosa:
      return "mucosa";
    case kLabelFat:
      return "fat";
    case kLabelCartilage:
      return "cartilage";
    case kLabelCancellousBone:
      return "cancellous-bone";
    case kLabelCorticalBone:
      return "cortical-bone";
    case kLabelTumour:
      return "tumour";
    case kLabelVessel:
      return "vessel";
    case kLabelNerve:
      return "nerve";
    case kLabelInvalid:
      return "invalid";
    default:
      if (is_overlay_label(label)) return "overlay";
      if (label >= kLabelFirstUser) return "user";
      return "tissue";
  }
}

std::string tissue_label_key(std::uint8_t label) {
  const std::string name = tissue_label_name(label);
  if (name == "overlay" || name == "user" || name == "tissue")
    return "label-" + std::to_string(static_cast<int>(label));
  return name;
}

}  // namespace tsf
