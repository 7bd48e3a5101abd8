#include "tsf/viewer/label_colours.h"

#include "tsf/volume/tissue_labels.h"

namespace tsf::viewer {

Rgb label_colour(std::uint8_t label) {
  switch (label) {
    case kLabelOutside:
      return {0, 0, 0};
    case kLabelSoftTissue:
      return {214, 140, 112};
    case kLabelMucosa:
      return {232, 92, 120};
    case kLabelFat:
      return {240, 212, 96};
    case kLabelCartilage:
      return {120, 196, 220};
    case kLabelCancellousBone:
      return {222, 214, 180};
    case kLabelCorticalBone:
      return {250, 248, 236};
    case kLabelTumour:
      return {150, 80, 200};
    case kLabelVessel:
      return {200, 30, 40};
    case kLabelNerve:
      return {250, 230, 60};
    default: {
      // A stable hue per value (golden-angle steps), full saturation, bright.
      const double h = static_cast<double>((label * 137) % 360) / 60.0;
      const int i = static_cast<int>(h);
      const double f = h - i;
      const auto up = static_cast<std::uint8_t>(255 * f),
                 down = static_cast<std::uint8_t>(255 * (1 - f));
      switch (i) {
        case 0:
          return {255, up, 0};
        case 1:
          return {down, 255, 0};
        case 2:
          return {0, 255, up};
        case 3:
          return {0, down, 255};
        case 4:
          return {up, 0, 255};
        default:
          return {255, 0, down};
      }
    }
  }
}

double label_overlay_opacity(std::uint8_t label) {
  if (label == kLabelOutside || label == kLabelInvalid) return 0.0;
  if (label == kLabelSoftTissue) return 0.25;
  return 0.6;
}

}  // namespace tsf::viewer
