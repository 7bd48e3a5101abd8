// The body mask of a CT: everything that belongs to the patient, nothing of the table, head-rest
// or the air around them.
//
// Steps (Input: HU image; Output: 0/1 mask on the same grid):
//   1. threshold  HU >= ThresholdHu                      (skin, fat, muscle, bone; also the table)
//   2. opening    ball of OpeningRadiusMm                (cuts thin contacts with table/head-rest)
//   3. largest 6-connected component                     (the patient)
//   4. restore    thresholded voxels within OpeningRadiusMm of it (opening removed thin detail:
//                 ears, nose tip, which come back; the table beyond the contact does not)
//   5. closing    ball of ClosingRadiusMm                (seals nostrils and pores of the skin)
//   6. hole fill  per slice normal to SliceAxis          (air inside the head joins the body)
//   7. margin     dilation by MarginMm                   (keeps the skin's partial-volume ramp)
// Throws itk::ExceptionObject when no voxel reaches the threshold (no body in the image).
#pragma once

#include <itkImageToImageFilter.h>

namespace tsf::segment {

template <typename TInputImage, typename TOutputImage>
class BodyMaskImageFilter : public itk::ImageToImageFilter<TInputImage, TOutputImage> {
 public:
  ITK_DISALLOW_COPY_AND_MOVE(BodyMaskImageFilter);

  using Self = BodyMaskImageFilter;
  using Superclass = itk::ImageToImageFilter<TInputImage, TOutputImage>;
  using Pointer = itk::SmartPointer<Self>;
  using ConstPointer = itk::SmartPointer<const Self>;

  itkNewMacro(Self)
  itkTypeMacro(BodyMaskImageFilter, ImageToImageFilter);
  itkSetMacro(ThresholdHu, double);
  itkGetConstMacro(ThresholdHu, double);
  itkSetMacro(OpeningRadiusMm, double);
  itkGetConstMacro(OpeningRadiusMm, double);
  itkSetMacro(ClosingRadiusMm, double);
  itkGetConstMacro(ClosingRadiusMm, double);
  itkSetMacro(FillHoles, bool);
  itkGetConstMacro(FillHoles, bool);
  itkBooleanMacro(FillHoles);
  itkSetMacro(MarginMm, double);
  itkGetConstMacro(MarginMm, double);
  /// Index axis normal to the slices filled in step 6 (the most superior-inferior one).
  itkSetMacro(SliceAxis, unsigned int);
  itkGetConstMacro(SliceAxis, unsigned int);

 protected:
  BodyMaskImageFilter() = default;
  ~BodyMaskImageFilter() override = default;

  void GenerateInputRequestedRegion() override;
  void EnlargeOutputRequestedRegion(itk::DataObject* output) override;
  void GenerateData() override;
  void PrintSelf(std::ostream& os, itk::Indent indent) const override;

 private:
  double m_ThresholdHu = -500.0;
  double m_OpeningRadiusMm = 3.0;
  double m_ClosingRadiusMm = 2.0;
  bool m_FillHoles = true;
  double m_MarginMm = 1.0;
  unsigned int m_SliceAxis = 2;
};

}  // namespace tsf::segment

#include "tsf/segment/filters/body_mask_image_filter.hxx"
