// Hysteresis threshold: voxels at or above WeakThreshold that are connected (26-neighbourhood,
// through such voxels) to at least one voxel at or above StrongThreshold.
//
// Why: a single bone threshold either misses thin sinus walls (partial volume brings them down to
// 200-400 HU) or picks up noise and contrast in soft tissue. Thin walls are connected to solid
// bone; isolated bright specks are not. (Canny's hysteresis, applied to connected components.)
// Input: HU image. Output: 0/1 mask.
#pragma once

#include <itkImageToImageFilter.h>

namespace tsf::segment {

template <typename TInputImage, typename TOutputImage>
class HysteresisThresholdImageFilter : public itk::ImageToImageFilter<TInputImage, TOutputImage> {
 public:
  ITK_DISALLOW_COPY_AND_MOVE(HysteresisThresholdImageFilter);

  using Self = HysteresisThresholdImageFilter;
  using Superclass = itk::ImageToImageFilter<TInputImage, TOutputImage>;
  using Pointer = itk::SmartPointer<Self>;
  using ConstPointer = itk::SmartPointer<const Self>;

  itkNewMacro(Self)
  itkTypeMacro(HysteresisThresholdImageFilter, ImageToImageFilter);
  itkSetMacro(WeakThreshold, double);
  itkGetConstMacro(WeakThreshold, double);
  itkSetMacro(StrongThreshold, double);
  itkGetConstMacro(StrongThreshold, double);

 protected:
  HysteresisThresholdImageFilter() = default;
  ~HysteresisThresholdImageFilter() override = default;

  void GenerateInputRequestedRegion() override;
  void EnlargeOutputRequestedRegion(itk::DataObject* output) override;
  void GenerateData() override;
  void PrintSelf(std::ostream& os, itk::Indent indent) const override;

 private:
  double m_WeakThreshold = 200.0;
  double m_StrongThreshold = 400.0;
};

}  // namespace tsf::segment

#include "tsf/segment/filters/hysteresis_threshold_image_filter.hxx"
