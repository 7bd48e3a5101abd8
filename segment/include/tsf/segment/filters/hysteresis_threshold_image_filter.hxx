#pragma once

#include <vector>

#include "tsf/segment/connected_components.h"

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
  const TInputImage* input = this->GetInput();
  const auto region = input->GetLargestPossibleRegion();
  const auto size = region.GetSize();
  const std::size_t n = region.GetNumberOfPixels();
  const auto* hu = input->GetBufferPointer();

  std::vector<unsigned char> weak(n);
  for (std::size_t v = 0; v < n; ++v)
    weak[v] = static_cast<double>(hu[v]) >= m_WeakThreshold ? 1 : 0;
  this->UpdateProgress(0.1f);
  const ComponentLabels components =
      label_connected_components(weak.data(), {size[0], size[1], size[2]}, true);
  this->UpdateProgress(0.8f);

  // Components holding a strong voxel are kept.
  std::vector<unsigned char> keep(components.sizes.size(), 0);
  for (std::size_t v = 0; v < n; ++v)
    if (components.labels[v] != 0 && static_cast<double>(hu[v]) >= m_StrongThreshold)
      keep[components.labels[v]] = 1;
  TOutputImage* output = this->GetOutput();
  output->SetBufferedRegion(region);
  output->Allocate();
  auto* out = output->GetBufferPointer();
  for (std::size_t v = 0; v < n; ++v) out[v] = keep[components.labels[v]] ? 1 : 0;
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
