#pragma once

#include <itkImageRegionConstIterator.h>
#include <itkImageRegionIterator.h>
#include <itkTotalProgressReporter.h>

#include "tsf/segment/filters/tissue_class_image_filter.h"

namespace tsf::segment {

template <typename THuImage, typename TDensityImage, typename TMaskImage, typename TLabelImage>
TissueClassImageFilter<THuImage, TDensityImage, TMaskImage, TLabelImage>::TissueClassImageFilter() {
  this->SetNumberOfRequiredInputs(2);
  this->DynamicMultiThreadingOn();
}

template <typename THuImage, typename TDensityImage, typename TMaskImage, typename TLabelImage>
void TissueClassImageFilter<THuImage, TDensityImage, TMaskImage, TLabelImage>::
    DynamicThreadedGenerateData(const OutputImageRegionType& region) {
  const auto* hu = this->GetInput();
  const auto* density = dynamic_cast<const TDensityImage*>(this->itk::ProcessObject::GetInput(1));
  const auto* bone = dynamic_cast<const TMaskImage*>(this->itk::ProcessObject::GetInput(2));
  if (!density) itkExceptionMacro("the density input (1) is missing or of the wrong type");
  auto* out = this->GetOutput();
  itk::TotalProgressReporter progress(this, out->GetRequestedRegion().GetNumberOfPixels());

  TissueClassRule rule = m_Rule;
  rule.bone_enabled = rule.bone_enabled && bone != nullptr;
  itk::ImageRegionConstIterator<THuImage> h(hu, region);
  itk::ImageRegionConstIterator<TDensityImage> d(density, region);
  itk::ImageRegionIterator<TLabelImage> l(out, region);
  if (bone) {
    itk::ImageRegionConstIterator<TMaskImage> b(bone, region);
    for (; !l.IsAtEnd(); ++h, ++d, ++b, ++l) {
      l.Set(classify_tissue_voxel(h.Get(), d.Get(), b.Get() != 0, rule));
      progress.CompletedPixel();
    }
  } else {
    for (; !l.IsAtEnd(); ++h, ++d, ++l) {
      l.Set(classify_tissue_voxel(h.Get(), d.Get(), false, rule));
      progress.CompletedPixel();
    }
  }
}

template <typename THuImage, typename TDensityImage, typename TMaskImage, typename TLabelImage>
void TissueClassImageFilter<THuImage, TDensityImage, TMaskImage, TLabelImage>::PrintSelf(
    std::ostream& os, itk::Indent indent) const {
  Superclass::PrintSelf(os, indent);
  os << indent << "BoneEnabled: " << m_Rule.bone_enabled << '\n'
     << indent << "CorticalHu: " << m_Rule.cortical_hu << '\n'
     << indent << "FatEnabled: " << m_Rule.fat_enabled << '\n'
     << indent << "FatRangeHu: " << m_Rule.fat_min_hu << " .. " << m_Rule.fat_max_hu << '\n';
}

}  // namespace tsf::segment
