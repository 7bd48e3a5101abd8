// Small synthetic images for the segment tests: blank grids and shapes painted in HU or labels.
#pragma once

#include <functional>

#include "tsf/segment/segment_image_types.h"

namespace tsf::segment::test {

/// An image of `size` voxels of `spacing` mm, origin 0, identity direction, filled with `value`.
template <typename Image>
typename Image::Pointer blank_image(int nx, int ny, int nz, typename Image::PixelType value,
                                    double sx = 1.0, double sy = 1.0, double sz = 1.0) {
  auto image = Image::New();
  typename Image::SizeType size;
  size[0] = static_cast<itk::SizeValueType>(nx);
  size[1] = static_cast<itk::SizeValueType>(ny);
  size[2] = static_cast<itk::SizeValueType>(nz);
  image->SetRegions(typename Image::RegionType(size));
  typename Image::SpacingType spacing;
  spacing[0] = sx;
  spacing[1] = sy;
  spacing[2] = sz;
  image->SetSpacing(spacing);
  image->Allocate();
  image->FillBuffer(value);
  return image;
}

/// Sets every voxel (i, j, k) for which `inside(i, j, k)` holds to `value`.
template <typename Image>
void paint(Image* image, typename Image::PixelType value,
           const std::function<bool(int, int, int)>& inside) {
  const auto size = image->GetLargestPossibleRegion().GetSize();
  auto* p = image->GetBufferPointer();
  std::size_t v = 0;
  for (int k = 0; k < static_cast<int>(size[2]); ++k)
    for (int j = 0; j < static_cast<int>(size[1]); ++j)
      for (int i = 0; i < static_cast<int>(size[0]); ++i, ++v)
        if (inside(i, j, k)) p[v] = value;
}

template <typename Image>
typename Image::PixelType at(const Image* image, int i, int j, int k) {
  typename Image::IndexType index;
  index[0] = i;
  index[1] = j;
  index[2] = k;
  return image->GetPixel(index);
}

}  // namespace tsf::segment::test
