// Colours and material names of tissue labels in exported files.
//
// Colours are the display colours of tsf's own PLY writer (imt::label_colour, 8-bit sRGB):
//   1 soft-tissue (214,150,140)  2 mucosa (232,120,130)  3 fat (240,215,130)
//   4 cartilage (170,200,230)    5 cancellous-bone (225,215,190)  6 cortical-bone (245,240,225)
//   7 tumour (150,90,160)        64 vessel (200,40,40)   65 nerve (240,220,60)
//   any other label: a stable hash colour with channels in [80, 240)
// glTF stores colours linearly (COLOR_0, baseColorFactor), so they go through the sRGB transfer
// function inverse there; OBJ, PLY and FBX get the 8-bit sRGB values (scaled to [0,1]).
//
// Surface looks (glTF metallic-roughness; every tissue is a dielectric, metallic 0): wet, smooth
// surfaces shine (mucosa 0.35, vessel 0.3), dry or porous ones do not (cancellous bone 0.85,
// cortical bone 0.6); soft tissue 0.55, fat 0.45, cartilage 0.4, tumour 0.5, nerve 0.45, any
// other label 0.6.
#pragma once

#include <array>
#include <cstdint>
#include <string>

namespace tsf::exporter {

/// 8-bit sRGB display colour of `label`.
std::array<std::uint8_t, 3> tissue_colour_srgb(std::uint8_t label);

/// The same colour as linear RGB in [0,1] (IEC 61966-2-1 inverse transfer function).
std::array<float, 3> tissue_colour_linear(std::uint8_t label);

/// sRGB-encoded 8-bit channel -> linear [0,1].
float srgb_to_linear(std::uint8_t channel);

/// glTF metallic-roughness factors of a tissue's material (see the top of this file).
struct TissueLook {
  float roughness = 0.6f;
  float metallic = 0.0f;
};
TissueLook tissue_look(std::uint8_t label);

/// Material / node name of a tissue: tissue_label_name for named labels ("mucosa",
/// "cortical-bone"), "<range>-<number>" for the others ("overlay-66", "user-130", "tissue-9").
std::string tissue_material_name(std::uint8_t label);

}  // namespace tsf::exporter
