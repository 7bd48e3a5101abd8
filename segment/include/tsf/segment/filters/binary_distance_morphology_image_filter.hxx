#pragma once

#include <itkImageRegionConstIterator.h>
#include <itkImageRegionIterator.h>
#include <itkImageRegionIteratorWithIndex.h>
#include <itkSignedMaurerDistanceMapImageFilter.h>

#include <algorithm>

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
  using DistanceImage = itk::Image<float, TImage::ImageDimension>;
  const auto region = mask->GetLargestPossibleRegion();

  // The distance map is computed to the foreground of `source` (the mask, or its complement).
  typename TImage::Pointer source = TImage::New();
  source->CopyInformation(mask);
  source->SetRegions(region);
  source->Allocate();
  {
    itk::ImageRegionConstIterator<TImage> in(mask, region);
    itk::ImageRegionIterator<TImage> out(source, region);
    for (; !in.IsAtEnd(); ++in, ++out) out.Set((in.Get() != 0) != invert ? 1 : 0);
  }

  typename TImage::Pointer result = TImage::New();
  result->CopyInformation(mask);
  result->SetRegions(region);
  result->Allocate();

  bool any_foreground = false;
  {
    itk::ImageRegionConstIterator<TImage> it(source, region);
    for (; !it.IsAtEnd() && !any_foreground; ++it) any_foreground = it.Get() != 0;
  }
  if (!any_foreground || m_RadiusMm <= 0.0) {
    // Radius 0: the dilation of `source` is itself. No foreground: the dilation is empty.
    itk::ImageRegionConstIterator<TImage> in(source, region);
    itk::ImageRegionIterator<TImage> out(result, region);
    for (; !in.IsAtEnd(); ++in, ++out)
      out.Set(((in.Get() != 0) && any_foreground) != invert ? 1 : 0);
  } else {
    auto distance = itk::SignedMaurerDistanceMapImageFilter<TImage, DistanceImage>::New();
    distance->SetInput(source);
    distance->SetUseImageSpacing(true);
    distance->SetSquaredDistance(true);
    distance->SetInsideIsPositive(false);
    distance->SetBackgroundValue(0);
    auto* distance_filter = distance.GetPointer();  // raw: the observer must not own its subject
    distance->AddObserver(itk::ProgressEvent(), [this, distance_filter, progress_from,
                                                 progress_to](const itk::EventObject&) {
      this->UpdateProgress(progress_from +
                           (progress_to - progress_from) * distance_filter->GetProgress());
    });
    distance->Update();

    // Foreground is inside (negative) or within the radius (squared distance <= r²).
    const float r2 = static_cast<float>(m_RadiusMm * m_RadiusMm);
    itk::ImageRegionConstIterator<DistanceImage> d(distance->GetOutput(), region);
    itk::ImageRegionIterator<TImage> out(result, region);
    for (; !d.IsAtEnd(); ++d, ++out) {
      const bool dilated = d.Get() <= r2;
      out.Set(dilated != invert ? 1 : 0);
    }
  }
  if (invert && m_BorderIsBackground) {
    // Erosion with background beyond the border: the nearest outside voxel lies straight across
    // the nearest face, at (index + 1)·spacing or (size − index)·spacing.
    const auto& spacing = mask->GetSpacing();
    const auto size = region.GetSize();
    const auto start = region.GetIndex();
    itk::ImageRegionIteratorWithIndex<TImage> it(result, region);
    for (; !it.IsAtEnd(); ++it) {
      if (it.Get() == 0) continue;
      const auto idx = it.GetIndex();
      for (unsigned int a = 0; a < TImage::ImageDimension; ++a) {
        const double i = static_cast<double>(idx[a] - start[a]);
        const double to_border = std::min(i + 1.0, static_cast<double>(size[a]) - i) * spacing[a];
        if (to_border <= m_RadiusMm) {
          it.Set(0);
          break;
        }
      }
    }
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
