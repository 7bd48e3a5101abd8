#pragma once

#include <itkBinaryThresholdImageFilter.h>
#include <itkImageRegionConstIterator.h>
#include <itkImageRegionIterator.h>
#include <itkProgressAccumulator.h>

#include <limits>

#include "tsf/segment/connected_components.h"
#include "tsf/segment/filters/binary_distance_morphology_image_filter.h"
#include "tsf/segment/filters/body_mask_image_filter.h"
#include "tsf/segment/filters/slice_hole_fill_image_filter.h"

namespace tsf::segment {

template <typename TInputImage, typename TOutputImage>
void BodyMaskImageFilter<TInputImage, TOutputImage>::GenerateInputRequestedRegion() {
  Superclass::GenerateInputRequestedRegion();
  if (auto* input = const_cast<TInputImage*>(this->GetInput()))
    input->SetRequestedRegionToLargestPossibleRegion();
}

template <typename TInputImage, typename TOutputImage>
void BodyMaskImageFilter<TInputImage, TOutputImage>::EnlargeOutputRequestedRegion(
    itk::DataObject* output) {
  Superclass::EnlargeOutputRequestedRegion(output);
  output->SetRequestedRegionToLargestPossibleRegion();
}

template <typename TInputImage, typename TOutputImage>
void BodyMaskImageFilter<TInputImage, TOutputImage>::GenerateData() {
  using Mask = TOutputImage;
  using Morphology = BinaryDistanceMorphologyImageFilter<Mask>;
  using InputPixel = typename TInputImage::PixelType;

  auto progress = itk::ProgressAccumulator::New();
  progress->SetMiniPipelineFilter(this);

  // 1. threshold
  auto threshold = itk::BinaryThresholdImageFilter<TInputImage, Mask>::New();
  threshold->SetInput(this->GetInput());
  threshold->SetLowerThreshold(static_cast<InputPixel>(m_ThresholdHu));
  threshold->SetUpperThreshold(std::numeric_limits<InputPixel>::max());
  threshold->SetInsideValue(1);
  threshold->SetOutsideValue(0);
  progress->RegisterInternalFilter(threshold, 0.05f);
  threshold->Update();
  const Mask* thresholded = threshold->GetOutput();

  // 2. opening
  auto opening = Morphology::New();
  opening->SetInput(thresholded);
  opening->SetOperation(MorphologyOperation::kOpen);
  opening->SetRadiusMm(m_OpeningRadiusMm);
  progress->RegisterInternalFilter(opening, 0.3f);
  opening->Update();

  // 3. largest 6-connected component
  const auto region = thresholded->GetLargestPossibleRegion();
  const auto size = region.GetSize();
  const Mask* opened = opening->GetOutput();
  const ComponentLabels components =
      label_connected_components(opened->GetBufferPointer(), {size[0], size[1], size[2]}, false);
  const std::uint32_t head = components.largest();
  if (head == 0)
    itkExceptionMacro("no body found: no voxel is at or above "
                      << m_ThresholdHu << " HU (after an opening of " << m_OpeningRadiusMm
                      << " mm)");
  typename Mask::Pointer largest = Mask::New();
  largest->CopyInformation(thresholded);
  largest->SetRegions(region);
  largest->Allocate();
  {
    auto* out = largest->GetBufferPointer();
    for (std::size_t v = 0; v < components.labels.size(); ++v)
      out[v] = components.labels[v] == head ? 1 : 0;
  }

  // 4. restore thresholded detail within the opening radius of the component
  auto restored = Morphology::New();
  restored->SetInput(largest);
  restored->SetOperation(MorphologyOperation::kDilate);
  restored->SetRadiusMm(m_OpeningRadiusMm);
  progress->RegisterInternalFilter(restored, 0.15f);
  restored->Update();
  {
    itk::ImageRegionConstIterator<Mask> t(thresholded, region);
    itk::ImageRegionIterator<Mask> out(restored->GetOutput(), region);
    for (; !t.IsAtEnd(); ++t, ++out) out.Set(out.Get() != 0 && t.Get() != 0 ? 1 : 0);
  }

  // 5. closing
  auto closing = Morphology::New();
  closing->SetInput(restored->GetOutput());
  closing->SetOperation(MorphologyOperation::kClose);
  closing->SetRadiusMm(m_ClosingRadiusMm);
  progress->RegisterInternalFilter(closing, 0.3f);
  closing->Update();
  typename Mask::Pointer body = closing->GetOutput();

  // 6. hole filling per slice
  if (m_FillHoles) {
    auto fill = SliceHoleFillImageFilter<Mask>::New();
    fill->SetInput(body);
    fill->SetSliceAxis(m_SliceAxis);
    progress->RegisterInternalFilter(fill, 0.1f);
    fill->Update();
    body = fill->GetOutput();
  }

  // 7. margin
  auto margin = Morphology::New();
  margin->SetInput(body);
  margin->SetOperation(MorphologyOperation::kDilate);
  margin->SetRadiusMm(m_MarginMm);
  progress->RegisterInternalFilter(margin, 0.1f);
  margin->Update();
  this->GraftOutput(margin->GetOutput());
}

template <typename TInputImage, typename TOutputImage>
void BodyMaskImageFilter<TInputImage, TOutputImage>::PrintSelf(std::ostream& os,
                                                               itk::Indent indent) const {
  Superclass::PrintSelf(os, indent);
  os << indent << "ThresholdHu: " << m_ThresholdHu << '\n'
     << indent << "OpeningRadiusMm: " << m_OpeningRadiusMm << '\n'
     << indent << "ClosingRadiusMm: " << m_ClosingRadiusMm << '\n'
     << indent << "FillHoles: " << m_FillHoles << '\n'
     << indent << "MarginMm: " << m_MarginMm << '\n'
     << indent << "SliceAxis: " << m_SliceAxis << '\n';
}

}  // namespace tsf::segment
