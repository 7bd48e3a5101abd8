#include "tsf/export/tissue_palette.h"

#include <cmath>

#include "tsf/imt/surface_ply.h"
#include "tsf/volume/tissue_labels.h"

namespace tsf::exporter {

std::array<std::uint8_t, 3> tissue_colour_srgb(std::uint8_t label) {
  return imt::label_colour(label);
}

float srgb_to_linear(std::uint8_t channel) {
  const double c = channel / 255.0;
  return static_cast<float>(c <= 0.04045 ? c / 12.92 : std::pow((c + 0.055) / 1.055, 2.4));
}

std::array<float, 3> tissue_colour_linear(std::uint8_t label) {
  const auto c = tissue_colour_srgb(label);
  return {srgb_to_linear(c[0]), srgb_to_linear(c[1]), srgb_to_linear(c[2])};
}

TissueLook tissue_look(std::uint8_t label) {
  switch (label) {
    case kLabelSoftTissue:
      return {0.55f, 0.0f};
    case kLabelMucosa:
      return {0.35f, 0.0f};
    case kLabelFat:
      return {0.45f, 0.0f};
    case kLabelCartilage:
      return {0.4f, 0.0f};
    case kLabelCancellousBone:
      return {0.85f, 0.0f};
    case kLabelCorticalBone:
      return {0.6f, 0.0f};
    case kLabelTumour:
      return {0.5f, 0.0f};
    case kLabelVessel:
      return {0.3f, 0.0f};
    case kLabelNerve:
      return {0.45f, 0.0f};
    default:
      return {};
  }
}

std::string tissue_material_name(std::uint8_t label) {
  const std::string name = tissue_label_name(label);
  // Generic range names would collide between labels: append the number.
  if (name == "overlay" || name == "user" || name == "tissue")
    return name + "-" + std::to_string(label);
  return name;
}

}  // namespace tsf::exporter
