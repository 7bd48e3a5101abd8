#include "tsf/segment/euclidean_distance_transform.h"

#include <itkMultiThreaderBase.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

namespace tsf::segment {

namespace {

constexpr float kInfinity = std::numeric_limits<float>::infinity();

/// One 1-D pass: d(p) = min_q f(q) + w²(p − q)² (F&H algorithm 1). Work arrays are the caller's
/// so a thread reuses them across lines.
void lower_envelope(const float* f, std::size_t n, double w, float* d, std::vector<int>& v,
                    std::vector<double>& z) {
  const double w2 = w * w;
  int k = -1;
  for (std::size_t qi = 0; qi < n; ++qi) {
    if (f[qi] == kInfinity) continue;  // no parabola from here
    const double q = static_cast<double>(qi);
    const double fq = static_cast<double>(f[qi]) + w2 * q * q;
    double s = -std::numeric_limits<double>::infinity();
    while (k >= 0) {
      const double p = static_cast<double>(v[k]);
      s = (fq - (static_cast<double>(f[v[k]]) + w2 * p * p)) / (2.0 * w2 * (q - p));
      if (s > z[k]) break;
      --k;
    }
    if (k < 0) s = -std::numeric_limits<double>::infinity();
    ++k;
    v[k] = static_cast<int>(qi);
    z[k] = s;
  }
  if (k < 0) {
    for (std::size_t p = 0; p < n; ++p) d[p] = kInfinity;
    return;
  }
  int j = 0;
  for (std::size_t pi = 0; pi < n; ++pi) {
    const double p = static_cast<double>(pi);
    while (j < k && z[j + 1] < p) ++j;
    const double dp = p - static_cast<double>(v[j]);
    d[pi] = static_cast<float>(w2 * dp * dp + static_cast<double>(f[v[j]]));
  }
}

}  // namespace

void squared_distance_to_foreground(const unsigned char* mask,
                                    const std::array<std::size_t, 3>& dims,
                                    const std::array<double, 3>& spacing, float* out,
                                    const std::function<void(double)>& progress) {
  const std::size_t nx = dims[0], ny = dims[1], nz = dims[2];
  auto threader = itk::MultiThreaderBase::New();

  // Pass 1 (x): distance along the row to the nearest foreground voxel, two sweeps.
  threader->ParallelizeArray(
      0, ny * nz,
      [&](itk::SizeValueType row) {
        const unsigned char* m = mask + row * nx;
        float* d = out + row * nx;
        const double sx = spacing[0];
        long last = -1;
        for (std::size_t i = 0; i < nx; ++i) {
          if (m[i]) last = static_cast<long>(i);
          const double gap = static_cast<double>(static_cast<long>(i) - last) * sx;
          d[i] = last < 0 ? kInfinity : static_cast<float>(gap * gap);
        }
        last = -1;
        for (std::size_t i = nx; i-- > 0;) {
          if (m[i]) last = static_cast<long>(i);
          if (last >= 0) {
            const double gap = static_cast<double>(last - static_cast<long>(i)) * sx;
            d[i] = std::min(d[i], static_cast<float>(gap * gap));
          }
        }
      },
      nullptr);
  if (progress) progress(1.0 / 3.0);

  // Passes 2 (y) and 3 (z): lower envelopes along strided lines. Lines are handled in bundles of
  // kBundle neighbouring x columns: the gather then reads kBundle contiguous floats per step
  // instead of one float per memory page (the z stride is a whole slice).
  constexpr std::size_t kBundle = 32;
  auto strided_pass = [&](std::size_t n, std::size_t stride, double w, std::size_t outer_count,
                          std::size_t outer_stride) {
    threader->ParallelizeArray(
        0, outer_count,
        [&, n, stride, w, outer_stride](itk::SizeValueType outer) {
          std::vector<float> block(n * kBundle), f(n), d(n);
          std::vector<int> v(n);
          std::vector<double> z(n + 1);
          for (std::size_t i0 = 0; i0 < nx; i0 += kBundle) {
            const std::size_t width = std::min(kBundle, nx - i0);
            float* base = out + outer * outer_stride + i0;
            for (std::size_t q = 0; q < n; ++q)
              std::copy(base + q * stride, base + q * stride + width, &block[q * kBundle]);
            for (std::size_t b = 0; b < width; ++b) {
              for (std::size_t q = 0; q < n; ++q) f[q] = block[q * kBundle + b];
              lower_envelope(f.data(), n, w, d.data(), v, z);
              for (std::size_t q = 0; q < n; ++q) block[q * kBundle + b] = d[q];
            }
            for (std::size_t q = 0; q < n; ++q)
              std::copy(&block[q * kBundle], &block[q * kBundle] + width, base + q * stride);
          }
        },
        nullptr);
  };
  // y: for each slice k, lines of ny with stride nx.
  strided_pass(ny, nx, spacing[1], nz, nx * ny);
  if (progress) progress(2.0 / 3.0);
  // z: for each row j, lines of nz with stride nx·ny.
  strided_pass(nz, nx * ny, spacing[2], ny, nx);
  if (progress) progress(1.0);
}

}  // namespace tsf::segment
