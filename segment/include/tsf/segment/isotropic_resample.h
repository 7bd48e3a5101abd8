// Resampling to isotropic voxels on the input's own axes.
//
// The output grid keeps the input's direction (LPS axes) and origin frame: output voxel n lies
// at input continuous index `first + n·(voxel_mm / input_spacing)` per axis. With the default box
// (the whole input) the origin is preserved exactly and the last output sample lies within one
// output voxel of the input's last sample, never beyond it (no extrapolation). Intensities are
// linearly interpolated.
#pragma once

#include <array>

#include "tsf/common/progress.h"
#include "tsf/common/vec3.h"
#include "tsf/segment/segment_image_types.h"

namespace tsf::segment {

/// An axis-aligned box in the input's continuous index space (voxel centres are integers):
/// first[a] <= last[a] on every axis a.
struct IndexBox {
  Vec3d first;
  Vec3d last;
};

/// The box of all voxel centres of `image`: [0, size-1] per axis.
IndexBox full_index_box(const HuImage* image);

/// The finest spacing of `image`, mm (the default isotropic voxel size).
double finest_spacing(const HuImage* image);

/// The isotropic grid that samples `box` of `input` every `voxel_mm`. Its first sample is at
/// `box.first`; size per axis = floor((last-first)·spacing/voxel_mm) + 1. Throws tsf::Error for
/// voxel_mm <= 0 or a grid over 2^31 voxels.
HuImage::Pointer make_isotropic_grid(const HuImage* input, double voxel_mm, const IndexBox& box);

/// Per-axis Gaussian σ (mm) that makes linear resampling from the input's spacing to `voxel_mm`
/// behave like partial-volume sampling at voxel_mm: a voxel integrates a box of width w
/// (variance w²/12) and the input already carries its own (s²/12), so the prefilter adds
/// σ² = (w² − s²)/12 on axes being coarsened, 0 elsewhere. Without it, going coarser point-samples
/// a sharp edge and the sub-voxel position is lost to aliasing (bench_segment --accuracy).
std::array<double, 3> antialias_sigma_mm(const HuImage* input, double voxel_mm);

/// Resamples `input` (linear interpolation) onto make_isotropic_grid(input, voxel_mm, box), with
/// the anti-aliasing prefilter when `antialias` (applied to the box's neighbourhood only).
HuImage::Pointer resample_isotropic(const HuImage* input, double voxel_mm, const IndexBox& box,
                                    bool antialias = true, Progress* progress = nullptr);

}  // namespace tsf::segment
