#pragma once

#include <itkBinaryThresholdImageFilter.h>
#include <itkConnectedComponentImageFilter.h>
#include <itkImageRegionConstIterator.h>
#include <itkImageRegionIterator.h>
#include <itkProgressAccumulator.h>

#include <limits>
#include <vector>

#include "tsf/segment/filters/hysteresis_threshold_image_filter.h"

namespace tsf::segment {

template <typename TInputImage, typename TOutputImage>
void HysteresisThresholdImageFilter<TInputImage, TOutputImage>::GenerateInputRequestedRegion() {
  Superclass::GenerateInputRequestedRegion();
  if (auto* input = const_cast<TInputImage*>(this->GetInput()))
    input->SetRequestedRegionToLargestPossibleRegion();
}

template <typename TInputImage, typename TOutputImage>
void HysteresisThresholdImageFilter<TInputImage, TOutputImage>::EnlargeOutputRequestedRegion(
    itk::DataObject* output) {
  Superclass::EnlargeOutputRequestedRegion(output);
  output->SetRequestedRegionToLargestPossibleRegion();
}

template <typename TInputImage, typename TOutputImage>
void HysteresisThresholdImageFilter<TInputImage, TOutputImage>::GenerateData() {
  if (!(m_WeakThreshold <= m_StrongThreshold))
    itkExceptionMacro("weak threshold " << m_WeakThreshold
                                        << " must not exceed the strong threshold "
                                        << m_StrongThreshold);
  using InputPixel = typename TInputImage::PixelType;
  using ComponentImage = itk::Image<unsigned int, TInputImage::ImageDimension>;
  const TInputImage* input = this->GetInput();
  const auto region = input->GetLargestPossibleRegion();

  auto progress = itk::ProgressAccumulator::New();
  progress->SetMiniPipelineFilter(this);

  auto weak = itk::BinaryThresholdImageFilter<TInputImage, TOutputImage>::New();
  weak->SetInput(input);
  weak->SetLowerThreshold(static_cast<InputPixel>(m_WeakThreshold));
  weak->SetUpperThreshold(std::numeric_limits<InputPixel>::max());
  weak->SetInsideValue(1);
  weak->SetOutsideValue(0);
  progress->RegisterInternalFilter(weak, 0.2f);

  auto components = itk::ConnectedComponentImageFilter<TOutputImage, ComponentImage>::New();
  components->SetInput(weak->GetOutput());
  components->FullyConnectedOn();
  progress->RegisterInternalFilter(components, 0.6f);
  components->Update();

  // Components holding a strong voxel are kept.
  std::vector<unsigned char> keep(static_cast<std::size_t>(components->GetObjectCount()) + 1, 0);
  const float strong = static_cast<float>(m_StrongThreshold);
  {
    itk::ImageRegionConstIterator<TInputImage> h(input, region);
    itk::ImageRegionConstIterator<ComponentImage> c(components->GetOutput(), region);
    for (; !h.IsAtEnd(); ++h, ++c)
      if (c.Get() != 0 && static_cast<float>(h.Get()) >= strong) keep[c.Get()] = 1;
  }
  TOutputImage* output = this->GetOutput();
  output->SetBufferedRegion(region);
  output->Allocate();
  itk::ImageRegionConstIterator<ComponentImage> c(components->GetOutput(), region);
  itk::ImageRegionIterator<TOutputImage> out(output, region);
  for (; !c.IsAtEnd(); ++c, ++out) out.Set(keep[c.Get()] ? 1 : 0);
  this->UpdateProgress(1.0f);
}

template <typename TInputImage, typename TOutputImage>
void HysteresisThresholdImageFilter<TInputImage, TOutputImage>::PrintSelf(
    std::ostream& os, itk::Indent indent) const {
  Superclass::PrintSelf(os, indent);
  os << indent << "WeakThreshold: " << m_WeakThreshold << '\n'
     << indent << "StrongThreshold: " << m_StrongThreshold << '\n';
}

}  // namespace tsf::segment
