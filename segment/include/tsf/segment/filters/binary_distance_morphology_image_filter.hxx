#pragma once

#include <algorithm>
#include <vector>

#include "tsf/segment/euclidean_distance_transform.h"
#include "tsf/segment/filters/binary_distance_morphology_image_filter.h"

namespace tsf::segment {

template <typename TImage>
void BinaryDistanceMorphologyImageFilter<TImage>::GenerateInputRequestedRegion() {
  Superclass::GenerateInputRequestedRegion();
  // A distance transform needs the whole image.
  if (auto* input = const_cast<TImage*>(this->GetInput()))
    input->SetRequestedRegionToLargestPossibleRegion();
}

template <typename TImage>
void BinaryDistanceMorphologyImageFilter<TImage>::EnlargeOutputRequestedRegion(
    itk::DataObject* output) {
  Superclass::EnlargeOutputRequestedRegion(output);
  output->SetRequestedRegionToLargestPossibleRegion();
}

template <typename TImage>
typename TImage::Pointer BinaryDistanceMorphologyImageFilter<TImage>::Dilate(const TImage* mask,
                                                                             bool invert,
                                                                             float progress_from,
                                                                             float progress_to) {
  static_assert(TImage::ImageDimension == 3, "the distance transform is 3-D");
  const auto region = mask->GetLargestPossibleRegion();
  if (mask->GetBufferedRegion() != region)
    itkExceptionMacro("the mask must be buffered whole, got " << mask->GetBufferedRegion());
  const std::size_t n = region.GetNumberOfPixels();
  const auto* in = mask->GetBufferPointer();

  typename TImage::Pointer result = TImage::New();
  result->CopyInformation(mask);
  result->SetRegions(region);
  result->Allocate();
  auto* out = result->GetBufferPointer();

  if (m_RadiusMm <= 0.0) {
    for (std::size_t v = 0; v < n; ++v) out[v] = in[v] != 0 ? 1 : 0;  // binarised copy
  } else {
    // Distances to the foreground of `source`: the mask, or its complement for an erosion. An
    // empty source gives +inf everywhere (nothing dilates), a full one 0 (everything does).
    std::vector<unsigned char> source(n);
    for (std::size_t v = 0; v < n; ++v) source[v] = (in[v] != 0) != invert ? 1 : 0;
    const auto size = region.GetSize();
    const auto& sp = mask->GetSpacing();
    std::vector<float> squared(n);
    squared_distance_to_foreground(
        source.data(), {size[0], size[1], size[2]}, {sp[0], sp[1], sp[2]}, squared.data(),
        [this, progress_from, progress_to](double fraction) {
          this->UpdateProgress(progress_from +
                               (progress_to - progress_from) * static_cast<float>(fraction));
        });
    const float r2 = static_cast<float>(m_RadiusMm * m_RadiusMm);
    for (std::size_t v = 0; v < n; ++v) out[v] = (squared[v] <= r2) != invert ? 1 : 0;
  }

  if (invert && m_BorderIsBackground) {
    // Erosion with background beyond the border: the nearest outside voxel lies straight across
    // the nearest face, at (index + 1)·spacing or (size − index)·spacing.
    const auto size = region.GetSize();
    const auto& sp = mask->GetSpacing();
    auto to_border = [&](unsigned int a, std::size_t i) {
      return std::min(static_cast<double>(i) + 1.0, static_cast<double>(size[a] - i)) * sp[a];
    };
    std::size_t v = 0;
    for (std::size_t k = 0; k < size[2]; ++k)
      for (std::size_t j = 0; j < size[1]; ++j)
        for (std::size_t i = 0; i < size[0]; ++i, ++v)
          if (out[v] && std::min({to_border(0, i), to_border(1, j), to_border(2, k)}) <= m_RadiusMm)
            out[v] = 0;
  }
  this->UpdateProgress(progress_to);
  return result;
}

template <typename TImage>
void BinaryDistanceMorphologyImageFilter<TImage>::GenerateData() {
  const TImage* input = this->GetInput();
  typename TImage::Pointer result;
  if (m_RadiusMm <= 0.0) {
    result = Dilate(input, false, 0.0f, 1.0f);  // radius 0: a binarised copy
  } else {
    switch (m_Operation) {
      case MorphologyOperation::kDilate:
        result = Dilate(input, false, 0.0f, 1.0f);
        break;
      case MorphologyOperation::kErode:
        result = Dilate(input, true, 0.0f, 1.0f);
        break;
      case MorphologyOperation::kOpen: {
        const auto eroded = Dilate(input, true, 0.0f, 0.5f);
        result = Dilate(eroded, false, 0.5f, 1.0f);
        break;
      }
      case MorphologyOperation::kClose: {
        const auto dilated = Dilate(input, false, 0.0f, 0.5f);
        result = Dilate(dilated, true, 0.5f, 1.0f);
        break;
      }
    }
  }
  this->GraftOutput(result);
}

template <typename TImage>
void BinaryDistanceMorphologyImageFilter<TImage>::PrintSelf(std::ostream& os,
                                                            itk::Indent indent) const {
  Superclass::PrintSelf(os, indent);
  os << indent << "RadiusMm: " << m_RadiusMm << '\n';
  os << indent << "Operation: " << static_cast<int>(m_Operation) << '\n';
  os << indent << "BorderIsBackground: " << m_BorderIsBackground << '\n';
}

}  // namespace tsf::segment
