#pragma once

#include <itkImageRegionConstIterator.h>
#include <itkImageRegionIterator.h>
#include <itkTotalProgressReporter.h>

#include <algorithm>

#include "tsf/segment/filters/hu_density_image_filter.h"
#include "tsf/segment/hu_density_ramp.h"

namespace tsf::segment {

template <typename THuImage, typename TMaskImage, typename TDensityImage>
HuDensityImageFilter<THuImage, TMaskImage, TDensityImage>::HuDensityImageFilter() {
  this->SetNumberOfRequiredInputs(1);
  this->DynamicMultiThreadingOn();
}

template <typename THuImage, typename TMaskImage, typename TDensityImage>
void HuDensityImageFilter<THuImage, TMaskImage, TDensityImage>::BeforeThreadedGenerateData() {
  if (!(m_LowerRampHu >= 0.0) || (m_UseUpperThreshold && !(m_UpperRampHu >= 0.0)))
    itkExceptionMacro("ramp widths must be >= 0 HU, got " << m_LowerRampHu << " and "
                                                          << m_UpperRampHu);
  if (m_UseUpperThreshold && !(m_UpperThresholdHu > m_LowerThresholdHu))
    itkExceptionMacro("upper threshold " << m_UpperThresholdHu
                                         << " HU must be above the lower threshold "
                                         << m_LowerThresholdHu << " HU");
  const auto* mask = dynamic_cast<const TMaskImage*>(this->itk::ProcessObject::GetInput(1));
  if (mask && mask->GetLargestPossibleRegion() != this->GetInput()->GetLargestPossibleRegion())
    itkExceptionMacro("the mask's region " << mask->GetLargestPossibleRegion()
                                           << " differs from the HU image's");
}

template <typename THuImage, typename TMaskImage, typename TDensityImage>
void HuDensityImageFilter<THuImage, TMaskImage, TDensityImage>::DynamicThreadedGenerateData(
    const OutputImageRegionType& region) {
  const THuImage* hu = this->GetInput();
  const auto* mask = dynamic_cast<const TMaskImage*>(this->itk::ProcessObject::GetInput(1));
  TDensityImage* out = this->GetOutput();
  itk::TotalProgressReporter progress(this, out->GetRequestedRegion().GetNumberOfPixels());

  const float lo_t = static_cast<float>(m_LowerThresholdHu);
  const float lo_w = static_cast<float>(m_LowerRampHu);
  const float hi_t = static_cast<float>(m_UpperThresholdHu);
  const float hi_w = static_cast<float>(m_UpperRampHu);
  itk::ImageRegionConstIterator<THuImage> h(hu, region);
  itk::ImageRegionIterator<TDensityImage> d(out, region);
  if (mask) {
    itk::ImageRegionConstIterator<TMaskImage> m(mask, region);
    for (; !d.IsAtEnd(); ++h, ++d, ++m) {
      float v = 0.0f;
      if (m.Get() != 0) {
        v = rising_density_ramp(h.Get(), lo_t, lo_w);
        if (m_UseUpperThreshold) v = std::min(v, falling_density_ramp(h.Get(), hi_t, hi_w));
      }
      d.Set(v);
      progress.CompletedPixel();
    }
  } else {
    for (; !d.IsAtEnd(); ++h, ++d) {
      float v = rising_density_ramp(h.Get(), lo_t, lo_w);
      if (m_UseUpperThreshold) v = std::min(v, falling_density_ramp(h.Get(), hi_t, hi_w));
      d.Set(v);
      progress.CompletedPixel();
    }
  }
}

template <typename THuImage, typename TMaskImage, typename TDensityImage>
void HuDensityImageFilter<THuImage, TMaskImage, TDensityImage>::PrintSelf(
    std::ostream& os, itk::Indent indent) const {
  Superclass::PrintSelf(os, indent);
  os << indent << "LowerThresholdHu: " << m_LowerThresholdHu << '\n'
     << indent << "LowerRampHu: " << m_LowerRampHu << '\n'
     << indent << "UseUpperThreshold: " << m_UseUpperThreshold << '\n'
     << indent << "UpperThresholdHu: " << m_UpperThresholdHu << '\n'
     << indent << "UpperRampHu: " << m_UpperRampHu << '\n';
}

}  // namespace tsf::segment
