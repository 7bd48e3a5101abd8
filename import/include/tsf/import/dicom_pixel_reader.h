// Decoding the pixels of one DICOM file through ITK's GDCMImageIO, into modality values.
//
// GDCM decodes every transfer syntax it supports (native, deflate, RLE, JPEG baseline/extended/
// lossless, JPEG-LS, JPEG 2000), masks BitsStored and sign-extends signed pixels, and applies
// the file's RescaleSlope/RescaleIntercept. What GDCM does not do is done here:
//   - per-frame rescale in enhanced multi-frame objects (GDCM applies the first frame's to
//     all): frames whose Pixel Value Transformation differs are re-mapped exactly,
//   - a Modality LUT Sequence (0028,3000) (GDCM ignores it).
// The declared pixel data size is checked against the header before GDCM allocates anything.
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "tsf/import/dicom_file_info.h"

namespace tsf::import {

struct DecodedFrameValues {
  double slope = 1, intercept = 0;  ///< the rescale GDCM applied
  int frames_remapped = 0;          ///< frames whose own rescale differed and was applied
  bool modality_lut_applied = false;
  std::string modality_lut_type;  ///< ModalityLUTType (0028,3004), e.g. "HU"
  /// Decoded in a decoder process: the peak resident memory it added for this file (bytes).
  std::uint64_t decoder_peak_bytes = 0;
};

/// Decodes all frames of `info` into `out`: columns×rows×number_of_frames floats, frame after
/// frame, each row-major. Throws tsf::Error naming the file, its transfer syntax and the cause.
DecodedFrameValues decode_dicom_frames(const DicomFileInfo& info, float* out);

/// Convenience: reads the header, then decodes every frame into a new vector.
std::vector<float> decode_dicom_file(const std::filesystem::path& path,
                                     DicomFileInfo* info_out = nullptr);

}  // namespace tsf::import
