// Fills holes of a binary mask slice by slice: in every 2-D slice normal to SliceAxis, background
// regions that cannot reach the slice border (4-connected) become foreground.
//
// Why slices and not 3-D: the nasal cavity and sinuses open to the outside through the nostrils
// and the airway, so in 3-D they are not holes; in axial slices they are enclosed by the head and
// a per-slice fill makes them part of the body. Every 3-D hole is also a hole in each slice
// through it, so this fills those too. Slices are independent and filled in parallel.
#pragma once

#include <itkImageToImageFilter.h>

namespace tsf::segment {

template <typename TImage>
class SliceHoleFillImageFilter : public itk::ImageToImageFilter<TImage, TImage> {
 public:
  ITK_DISALLOW_COPY_AND_MOVE(SliceHoleFillImageFilter);

  using Self = SliceHoleFillImageFilter;
  using Superclass = itk::ImageToImageFilter<TImage, TImage>;
  using Pointer = itk::SmartPointer<Self>;
  using ConstPointer = itk::SmartPointer<const Self>;

  itkNewMacro(Self)
  itkTypeMacro(SliceHoleFillImageFilter, ImageToImageFilter);
  /// Index axis the slices are normal to (2 = k, axial for a usual CT).
  itkSetMacro(SliceAxis, unsigned int);
  itkGetConstMacro(SliceAxis, unsigned int);

 protected:
  SliceHoleFillImageFilter() = default;
  ~SliceHoleFillImageFilter() override = default;

  void GenerateInputRequestedRegion() override;
  void EnlargeOutputRequestedRegion(itk::DataObject* output) override;
  void GenerateData() override;
  void PrintSelf(std::ostream& os, itk::Indent indent) const override;

 private:
  unsigned int m_SliceAxis = 2;
};

}  // namespace tsf::segment

#include "tsf/segment/filters/slice_hole_fill_image_filter.hxx"
