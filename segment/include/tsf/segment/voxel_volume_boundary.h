// The one place where segmentation output (ITK images) becomes the tissue core's R1 volume.
//
// Geometry is copied unchanged: dims, spacing (mm), origin (LPS position of voxel (0,0,0)'s
// centre, mm) and direction (columns = index axes in LPS), so the volume written by
// tsf::import::write_tissue_volume overlays the CT it came from.
#pragma once

#include "tsf/segment/segmentation_pipeline.h"
#include "tsf/volume/voxel_volume.h"

namespace tsf::segment {

/// Density and labels are required, weights optional. Throws tsf::Error when an image is missing
/// or the grids differ.
VoxelVolume to_voxel_volume(const SegmentationImages& images);

}  // namespace tsf::segment
