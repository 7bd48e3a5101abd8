// The ITK image types the segmentation pipeline passes between its stages.
//
// Every image shares one grid after resampling: isotropic spacing (mm), the input's origin frame
// and direction (LPS). Pixel meanings:
//   HuImage       float, Hounsfield units (air -1000, water 0)
//   MaskImage     uint8, 0 = off, 1 = on (body mask, air spaces, bone hysteresis)
//   LabelImage    uint8, TissueLabel values (tsf/volume/tissue_labels.h)
//   DensityImage  float in [0,1]; the tissue surface is its 0.5 iso-level
//   WeightImage   4 × uint8 material blend weights per voxel, summing to 255
#pragma once

#include <itkImage.h>
#include <itkVector.h>

namespace tsf::segment {

constexpr unsigned int kImageDimension = 3;
constexpr unsigned int kMaterialChannels = 4;

using HuImage = itk::Image<float, kImageDimension>;
using MaskImage = itk::Image<unsigned char, kImageDimension>;
using LabelImage = itk::Image<unsigned char, kImageDimension>;
using DensityImage = itk::Image<float, kImageDimension>;
using WeightPixel = itk::Vector<unsigned char, kMaterialChannels>;
using WeightImage = itk::Image<WeightPixel, kImageDimension>;

}  // namespace tsf::segment
