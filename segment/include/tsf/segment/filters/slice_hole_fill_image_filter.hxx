#pragma once

#include <itkMultiThreaderBase.h>

#include <algorithm>
#include <vector>

#include "tsf/segment/filters/slice_hole_fill_image_filter.h"

namespace tsf::segment {

template <typename TImage>
void SliceHoleFillImageFilter<TImage>::GenerateInputRequestedRegion() {
  Superclass::GenerateInputRequestedRegion();
  if (auto* input = const_cast<TImage*>(this->GetInput()))
    input->SetRequestedRegionToLargestPossibleRegion();
}

template <typename TImage>
void SliceHoleFillImageFilter<TImage>::EnlargeOutputRequestedRegion(itk::DataObject* output) {
  Superclass::EnlargeOutputRequestedRegion(output);
  output->SetRequestedRegionToLargestPossibleRegion();
}

template <typename TImage>
void SliceHoleFillImageFilter<TImage>::GenerateData() {
  static_assert(TImage::ImageDimension == 3, "SliceHoleFillImageFilter works on 3-D images");
  if (m_SliceAxis > 2) itkExceptionMacro("SliceAxis must be 0, 1 or 2, got " << m_SliceAxis);

  const TImage* input = this->GetInput();
  TImage* output = this->GetOutput();
  const auto region = input->GetLargestPossibleRegion();
  output->SetBufferedRegion(region);
  output->Allocate();

  const auto size = region.GetSize();
  const std::size_t n[3] = {size[0], size[1], size[2]};
  const std::size_t stride[3] = {1, n[0], n[0] * n[1]};
  // The two in-slice axes (u fastest) and the slice axis.
  const unsigned int ua = m_SliceAxis == 0 ? 1 : 0;
  const unsigned int va = m_SliceAxis == 2 ? 1 : 2;
  const std::size_t nu = n[ua], nv = n[va];
  const auto* in = input->GetBufferPointer();
  auto* out = output->GetBufferPointer();

  auto fill_slice = [&](itk::SizeValueType s) {
    // Flood the background from the slice border; unreached background is a hole.
    std::vector<unsigned char> reached(nu * nv, 0);
    std::vector<std::size_t> stack;
    auto voxel = [&](std::size_t u, std::size_t v) {
      return u * stride[ua] + v * stride[va] + static_cast<std::size_t>(s) * stride[m_SliceAxis];
    };
    auto push = [&](std::size_t u, std::size_t v) {
      const std::size_t p = u + nu * v;
      if (!reached[p] && in[voxel(u, v)] == 0) {
        reached[p] = 1;
        stack.push_back(p);
      }
    };
    for (std::size_t u = 0; u < nu; ++u) {
      push(u, 0);
      push(u, nv - 1);
    }
    for (std::size_t v = 0; v < nv; ++v) {
      push(0, v);
      push(nu - 1, v);
    }
    while (!stack.empty()) {
      const std::size_t p = stack.back();
      stack.pop_back();
      const std::size_t u = p % nu, v = p / nu;
      if (u > 0) push(u - 1, v);
      if (u + 1 < nu) push(u + 1, v);
      if (v > 0) push(u, v - 1);
      if (v + 1 < nv) push(u, v + 1);
    }
    for (std::size_t v = 0; v < nv; ++v)
      for (std::size_t u = 0; u < nu; ++u) {
        const std::size_t i = voxel(u, v);
        out[i] = (in[i] != 0 || !reached[u + nu * v]) ? 1 : 0;
      }
  };

  this->GetMultiThreader()->ParallelizeArray(0, n[m_SliceAxis], fill_slice, this);
}

template <typename TImage>
void SliceHoleFillImageFilter<TImage>::PrintSelf(std::ostream& os, itk::Indent indent) const {
  Superclass::PrintSelf(os, indent);
  os << indent << "SliceAxis: " << m_SliceAxis << '\n';
}

}  // namespace tsf::segment
