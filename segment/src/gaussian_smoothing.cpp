#include "tsf/segment/gaussian_smoothing.h"

#include <itkGaussianOperator.h>
#include <itkImageDuplicator.h>
#include <itkMultiThreaderBase.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "tsf/common/error.h"

namespace tsf::segment {

namespace {

/// The discrete Gaussian kernel (Lindeberg's e^{−t} I_n(t), as itk::DiscreteGaussianImageFilter
/// uses) for variance `variance_voxels` in voxel units, cut at 1% tail mass.
std::vector<float> gaussian_kernel(double variance_voxels) {
  itk::GaussianOperator<double, 1> op;
  op.SetVariance(variance_voxels);
  op.SetMaximumError(0.01);
  op.SetMaximumKernelWidth(1024);
  op.CreateDirectional();
  std::vector<float> kernel(op.Size());
  for (std::size_t i = 0; i < op.Size(); ++i) kernel[i] = static_cast<float>(op[i]);
  return kernel;
}

}  // namespace

HuImage::Pointer gaussian_smooth(const HuImage* image, double sigma_mm, Progress* progress,
                                 double progress_from, double progress_to) {
  return gaussian_smooth(image, {sigma_mm, sigma_mm, sigma_mm}, progress, progress_from,
                         progress_to);
}

HuImage::Pointer gaussian_smooth(const HuImage* image, const std::array<double, 3>& sigma_mm,
                                 Progress* progress, double progress_from, double progress_to) {
  auto copy = itk::ImageDuplicator<HuImage>::New();
  copy->SetInputImage(image);
  copy->Update();
  HuImage::Pointer out = copy->GetOutput();
  for (double s : sigma_mm)
    if (std::isnan(s) || std::isinf(s))
      throw Error("Gaussian smoothing: sigma must be finite, got " + std::to_string(s) + " mm");
  if (!(sigma_mm[0] > 0.0 || sigma_mm[1] > 0.0 || sigma_mm[2] > 0.0)) return out;

  const auto size = image->GetLargestPossibleRegion().GetSize();
  const std::size_t n[3] = {size[0], size[1], size[2]};
  const std::size_t stride[3] = {1, n[0], n[0] * n[1]};
  const auto& spacing = image->GetSpacing();
  std::vector<float> scratch(out->GetLargestPossibleRegion().GetNumberOfPixels());
  float* a = out->GetBufferPointer();
  float* b = scratch.data();
  auto threader = itk::MultiThreaderBase::New();

  // One separable pass per axis, a -> b, then swap. Along the axis each output sample is the
  // kernel-weighted sum of its neighbours, the border replicated (zero-flux Neumann, as ITK).
  // Lines are processed in bundles of whole rows so the inner loop runs over contiguous x.
  for (unsigned int axis = 0; axis < 3; ++axis) {
    if (!(sigma_mm[axis] > 0.0)) {
      if (progress)
        progress->set_fraction(progress_from + (progress_to - progress_from) * (axis + 1) / 3.0);
      continue;  // no pass, no swap
    }
    const std::vector<float> kernel =
        gaussian_kernel(sigma_mm[axis] * sigma_mm[axis] / (spacing[axis] * spacing[axis]));
    const int radius = static_cast<int>(kernel.size() / 2);
    const long len = static_cast<long>(n[axis]);
    if (axis == 0) {
      threader->ParallelizeArray(
          0, n[1] * n[2],
          [&](itk::SizeValueType row) {
            const float* in = a + row * n[0];
            float* o = b + row * n[0];
            for (long i = 0; i < len; ++i) {
              float sum = 0.0f;
              for (int t = -radius; t <= radius; ++t)
                sum += kernel[t + radius] * in[std::clamp(i + t, 0L, len - 1)];
              o[i] = sum;
            }
          },
          nullptr);
    } else {
      // For y: one task per slice k, rows j; for z: one task per row j, slices k.
      const std::size_t tasks = axis == 1 ? n[2] : n[1];
      threader->ParallelizeArray(
          0, tasks,
          [&, axis](itk::SizeValueType task) {
            for (long p = 0; p < len; ++p) {
              const std::size_t base = axis == 1 ? task * stride[2] : task * stride[1];
              float* o = b + base + static_cast<std::size_t>(p) * stride[axis];
              std::fill(o, o + n[0], 0.0f);
              for (int t = -radius; t <= radius; ++t) {
                const std::size_t q = static_cast<std::size_t>(std::clamp(p + t, 0L, len - 1));
                const float* in = a + base + q * stride[axis];
                const float w = kernel[t + radius];
                for (std::size_t i = 0; i < n[0]; ++i) o[i] += w * in[i];
              }
            }
          },
          nullptr);
    }
    std::swap(a, b);
    if (progress)
      progress->set_fraction(progress_from + (progress_to - progress_from) * (axis + 1) / 3.0);
  }
  // After an odd number of passes the result is in the scratch buffer.
  if (a != out->GetBufferPointer()) std::copy(a, a + scratch.size(), out->GetBufferPointer());
  return out;
}

}  // namespace tsf::segment
