// Smoothed HU + density + bone mask -> tissue labels, voxel by voxel (hu_tissue_class.h).
//
// Inputs: 0 = HU image (smoothed), 1 = density (float [0,1]), 2 = bone mask (0/1; optional).
// Output: label image (TissueLabel values).
#pragma once

#include <itkImageToImageFilter.h>

#include "tsf/segment/hu_tissue_class.h"

namespace tsf::segment {

template <typename THuImage, typename TDensityImage, typename TMaskImage, typename TLabelImage>
class TissueClassImageFilter : public itk::ImageToImageFilter<THuImage, TLabelImage> {
 public:
  ITK_DISALLOW_COPY_AND_MOVE(TissueClassImageFilter);

  using Self = TissueClassImageFilter;
  using Superclass = itk::ImageToImageFilter<THuImage, TLabelImage>;
  using Pointer = itk::SmartPointer<Self>;
  using ConstPointer = itk::SmartPointer<const Self>;
  using OutputImageRegionType = typename TLabelImage::RegionType;

  itkNewMacro(Self)
  itkTypeMacro(TissueClassImageFilter, ImageToImageFilter);
  void SetHuImage(const THuImage* hu) { this->SetNthInput(0, const_cast<THuImage*>(hu)); }
  void SetDensityImage(const TDensityImage* density) {
    this->SetNthInput(1, const_cast<TDensityImage*>(density));
  }
  void SetBoneMask(const TMaskImage* bone) { this->SetNthInput(2, const_cast<TMaskImage*>(bone)); }

  void SetRule(const TissueClassRule& rule) {
    m_Rule = rule;
    this->Modified();
  }
  const TissueClassRule& GetRule() const { return m_Rule; }

 protected:
  TissueClassImageFilter();
  ~TissueClassImageFilter() override = default;

  void DynamicThreadedGenerateData(const OutputImageRegionType& region) override;
  void PrintSelf(std::ostream& os, itk::Indent indent) const override;

 private:
  TissueClassRule m_Rule;
};

}  // namespace tsf::segment

#include "tsf/segment/filters/tissue_class_image_filter.hxx"
