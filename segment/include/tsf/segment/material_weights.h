// Material blend weights: per voxel, how much of each of the 4 palette channels it is made of.
//
// Each tissue label maps to channel fractions (preset materials.classes). To give the lattice
// smooth heterogeneity instead of stair steps at class boundaries, the per-channel fraction
// fields are blended by normalised convolution over the tissue:
//   w_c = G_σ * (f_c · T) / G_σ * T        T = 1 on tissue voxels (labels 1..127), else 0
// so a voxel deep inside one class keeps that class's fractions exactly, voxels near a boundary
// mix their neighbours' classes, and the air is never mixed in. Voxels outside the tissue get the
// blended weights of the tissue near them (lattice nodes there still sample sensible values);
// voxels with no tissue within reach get {255, 0, 0, 0}. Quantised to sum to 255
// (material_weight_quantization.h).
#pragma once

#include "tsf/common/progress.h"
#include "tsf/segment/segment_image_types.h"
#include "tsf/segment/segment_preset.h"

namespace tsf::segment {

/// `labels` on an isotropic or anisotropic grid (σ is in mm). Throws tsf::Error naming a label
/// that occurs but has no channel mapping.
WeightImage::Pointer material_weights(const LabelImage* labels, const MaterialSettings& materials,
                                      Progress* progress = nullptr);

}  // namespace tsf::segment
