#include "tsf/segment/material_weights.h"

#include <array>
#include <string>
#include <vector>

#include "tsf/common/error.h"
#include "tsf/segment/gaussian_smoothing.h"
#include "tsf/segment/material_weight_quantization.h"
#include "tsf/volume/tissue_labels.h"

namespace tsf::segment {

namespace {

bool counts_as_tissue(std::uint8_t label) {
  return is_tissue_label(label) || is_overlay_label(label);
}

HuImage::Pointer float_image_like(const LabelImage* labels) {
  auto image = HuImage::New();
  image->CopyInformation(labels);
  image->SetRegions(labels->GetLargestPossibleRegion());
  image->Allocate();
  return image;
}

}  // namespace

WeightImage::Pointer material_weights(const LabelImage* labels, const MaterialSettings& materials,
                                      Progress* progress) {
  const std::size_t n = labels->GetLargestPossibleRegion().GetNumberOfPixels();
  const unsigned char* label = labels->GetBufferPointer();

  std::array<bool, 256> present{};
  for (std::size_t v = 0; v < n; ++v) present[label[v]] = true;
  std::array<std::array<float, kMaterialChannels>, 256> fractions{};
  std::array<bool, kMaterialChannels> channel_used{};
  for (int l = 0; l < 256; ++l) {
    if (!present[l] || !counts_as_tissue(static_cast<std::uint8_t>(l))) continue;
    const auto it = materials.class_fractions.find(static_cast<std::uint8_t>(l));
    if (it == materials.class_fractions.end())
      throw Error("material weights: label " + std::to_string(l) + " (" +
                  tissue_label_name(static_cast<std::uint8_t>(l)) +
                  ") occurs but the preset maps it to no channel (materials.classes)");
    for (std::size_t c = 0; c < kMaterialChannels; ++c) {
      fractions[l][c] = static_cast<float>(it->second[c]);
      channel_used[c] = channel_used[c] || it->second[c] > 0.0;
    }
  }

  auto out = WeightImage::New();
  out->CopyInformation(labels);
  out->SetRegions(labels->GetLargestPossibleRegion());
  out->Allocate();
  WeightPixel* w = out->GetBufferPointer();
  auto to_pixel = [](const std::array<std::uint8_t, 4>& q) {
    WeightPixel p;
    for (unsigned int c = 0; c < kMaterialChannels; ++c) p[c] = q[c];
    return p;
  };
  const WeightPixel fallback = to_pixel({255, 0, 0, 0});

  if (!(materials.blend_sigma_mm > 0.0)) {
    for (std::size_t v = 0; v < n; ++v)
      w[v] = counts_as_tissue(label[v]) ? to_pixel(quantize_material_weights(fractions[label[v]]))
                                        : fallback;
    if (progress) progress->set_fraction(1.0);
    return out;
  }

  // Normalised convolution: blur the tissue indicator and each used channel's fraction field.
  std::vector<std::size_t> used;
  for (std::size_t c = 0; c < kMaterialChannels; ++c)
    if (channel_used[c]) used.push_back(c);
  const double share = 1.0 / static_cast<double>(used.size() + 1);
  const double sigma = materials.blend_sigma_mm;

  HuImage::Pointer tissue = float_image_like(labels);
  {
    float* t = tissue->GetBufferPointer();
    for (std::size_t v = 0; v < n; ++v) t[v] = counts_as_tissue(label[v]) ? 1.0f : 0.0f;
  }
  const HuImage::Pointer tissue_blur = gaussian_smooth(tissue, sigma, progress, 0.0, share);
  tissue = nullptr;

  std::array<HuImage::Pointer, kMaterialChannels> channel_blur;
  for (std::size_t u = 0; u < used.size(); ++u) {
    const std::size_t c = used[u];
    HuImage::Pointer field = float_image_like(labels);
    float* f = field->GetBufferPointer();
    for (std::size_t v = 0; v < n; ++v)
      f[v] = counts_as_tissue(label[v]) ? fractions[label[v]][c] : 0.0f;
    channel_blur[c] = gaussian_smooth(field, sigma, progress, share * static_cast<double>(u + 1),
                                      share * static_cast<double>(u + 2));
  }

  const float* tb = tissue_blur->GetBufferPointer();
  // Below this much blurred tissue the ratio is noise: the voxel is far from any tissue.
  constexpr float kMinTissue = 1e-3f;
  for (std::size_t v = 0; v < n; ++v) {
    if (!(tb[v] > kMinTissue)) {
      w[v] = fallback;
      continue;
    }
    std::array<float, 4> mix{};
    for (std::size_t c : used) mix[c] = channel_blur[c]->GetBufferPointer()[v] / tb[v];
    w[v] = to_pixel(quantize_material_weights(mix));
  }
  if (progress) progress->set_fraction(1.0);
  return out;
}

}  // namespace tsf::segment
