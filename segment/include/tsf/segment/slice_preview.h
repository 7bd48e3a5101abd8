// A picture people can look at: labelled axial, coronal and sagittal slices over the CT (PNG).
//
// Each panel shows the resampled HU in a grey window with the tissue classes tinted over it and
// the air spaces inside the body in blue; a legend names each colour with its volume. Slices pass
// through the centroid of the air spaces (the sinuses and nasal cavity in a head) when there are
// any, else through the centroid of the tissue. Panels are drawn in index axes: axial = (i right,
// j down), coronal = (i right, k up), sagittal = (j right, k up). With the anatomy, the edges carry
// orientation letters and the landmarks are marked.
#pragma once

#include <array>
#include <filesystem>

#include "tsf/segment/segmentation_pipeline.h"
#include "tsf/segment/segmentation_report.h"
#include "tsf/segment/sinus_anatomy.h"

namespace tsf::segment {

struct SlicePreviewOptions {
  double window_min_hu = -1000.0;  ///< black
  double window_max_hu = 1400.0;   ///< white
  int scale = 0;                   ///< pixels per voxel; 0 = smallest making panels >= 320 px
  float tint = 0.45f;              ///< opacity of the class colours
  /// When given: its landmarks are marked (crosses, projected onto every panel), the nasal
  /// cavity's box outlined, and the panel edges lettered with the patient directions (L/R, A/P
  /// from the detected facing, S/I; "L/R UNKNOWN" when the CT records no orientation).
  const SinusAnatomy* anatomy = nullptr;
};

struct SlicePreviewInfo {
  std::array<int, 3> slice_index{};  ///< sagittal i, coronal j, axial k
  int width = 0, height = 0;         ///< of the PNG, pixels
};

/// Writes the PNG atomically. Throws tsf::Error naming the path on failure.
SlicePreviewInfo write_slice_preview(const std::filesystem::path& png,
                                     const SegmentationImages& images,
                                     const SegmentationStatistics& stats,
                                     const SlicePreviewOptions& options = {});

/// The colour a label is tinted with (RGB).
std::array<unsigned char, 3> label_preview_colour(unsigned char label);

}  // namespace tsf::segment
