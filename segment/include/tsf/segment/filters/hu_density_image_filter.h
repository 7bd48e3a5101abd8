// HU -> density in [0,1]: a clamped linear ramp around the tissue threshold (hu_density_ramp.h),
// optionally a band with an upper threshold, zero outside the body mask.
//
// Inputs: 0 = HU image (smoothed), 1 = body mask (0/1, same grid; optional: no mask = all body).
// Output: density image, float in [0,1].
#pragma once

#include <itkImageToImageFilter.h>

namespace tsf::segment {

template <typename THuImage, typename TMaskImage, typename TDensityImage>
class HuDensityImageFilter : public itk::ImageToImageFilter<THuImage, TDensityImage> {
 public:
  ITK_DISALLOW_COPY_AND_MOVE(HuDensityImageFilter);

  using Self = HuDensityImageFilter;
  using Superclass = itk::ImageToImageFilter<THuImage, TDensityImage>;
  using Pointer = itk::SmartPointer<Self>;
  using ConstPointer = itk::SmartPointer<const Self>;
  using OutputImageRegionType = typename TDensityImage::RegionType;

  itkNewMacro(Self)
  itkTypeMacro(HuDensityImageFilter, ImageToImageFilter);
  void SetHuImage(const THuImage* hu) { this->SetNthInput(0, const_cast<THuImage*>(hu)); }
  void SetMaskImage(const TMaskImage* mask) { this->SetNthInput(1, const_cast<TMaskImage*>(mask)); }

  itkSetMacro(LowerThresholdHu, double);
  itkGetConstMacro(LowerThresholdHu, double);
  itkSetMacro(LowerRampHu, double);
  itkGetConstMacro(LowerRampHu, double);
  /// Upper boundary (tissue is a band between the thresholds); off by default.
  itkSetMacro(UseUpperThreshold, bool);
  itkGetConstMacro(UseUpperThreshold, bool);
  itkSetMacro(UpperThresholdHu, double);
  itkGetConstMacro(UpperThresholdHu, double);
  itkSetMacro(UpperRampHu, double);
  itkGetConstMacro(UpperRampHu, double);

 protected:
  HuDensityImageFilter();
  ~HuDensityImageFilter() override = default;

  void BeforeThreadedGenerateData() override;
  void DynamicThreadedGenerateData(const OutputImageRegionType& region) override;
  void PrintSelf(std::ostream& os, itk::Indent indent) const override;

 private:
  double m_LowerThresholdHu = -480.0;
  double m_LowerRampHu = 800.0;
  bool m_UseUpperThreshold = false;
  double m_UpperThresholdHu = 300.0;
  double m_UpperRampHu = 400.0;
};

}  // namespace tsf::segment

#include "tsf/segment/filters/hu_density_image_filter.hxx"
