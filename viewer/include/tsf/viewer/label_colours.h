// Colours of tissue labels (tsf/volume/tissue_labels.h) in the viewer: the surface is coloured
// per vertex by the label of the tissue it bounds, and the slice planes overlay the same colours.
// Chosen to read apart under flat lighting: warm soft tissue, pale bone, pink mucosa.
#pragma once

#include <array>
#include <cstdint>

namespace tsf::viewer {

using Rgb = std::array<std::uint8_t, 3>;

/// Display colour of `label` (8-bit sRGB). Unknown labels get a stable hue from their value.
Rgb label_colour(std::uint8_t label);

/// Overlay opacity of `label` on slice planes in [0, 1]: 0 outside the tissue, lower for the
/// bulk soft tissue so the grey CT shows through, higher for thin structures.
double label_overlay_opacity(std::uint8_t label);

}  // namespace tsf::viewer
