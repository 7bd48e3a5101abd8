// Native (uncompressed) DICOM pixel data, decoded by tsf itself: no codec library runs.
//
// DCMTK, which already parsed every header in this process, hands over the raw bytes of the
// Pixel Data value (in the machine's byte order); tsf takes BitsStored bits below HighBit,
// sign-extends signed samples and applies each frame's rescale. The header pass has checked
// that the file holds every byte the header declares, so nothing here is sized by a claim
// (robustness.md, "Pixel decoding").
#pragma once

#include "tsf/import/dicom_file_info.h"
#include "tsf/import/dicom_pixel_reader.h"

namespace tsf::import {

/// Decodes every frame of a native-encoded `info` into `out` (columns×rows×frames floats).
/// Throws tsf::Error naming the file.
DecodedFrameValues decode_native_frames(const DicomFileInfo& info, float* out);

/// The value of one stored sample `raw` (the allocated bits as read) after taking BitsStored
/// bits below HighBit and sign-extending a signed sample.
inline std::int64_t stored_sample_value(std::uint32_t raw, int bits_stored, int high_bit,
                                        bool is_signed) {
  const int shift = high_bit + 1 - bits_stored;
  const std::uint32_t mask =
      bits_stored >= 32 ? 0xFFFFFFFFu : ((std::uint32_t{1} << bits_stored) - 1u);
  const std::uint32_t v = (raw >> shift) & mask;
  if (!is_signed || bits_stored >= 32)
    return is_signed ? static_cast<std::int64_t>(static_cast<std::int32_t>(v))
                     : static_cast<std::int64_t>(v);
  const std::uint32_t sign = std::uint32_t{1} << (bits_stored - 1);
  return (v & sign) ? static_cast<std::int64_t>(v) - (std::int64_t{1} << bits_stored)
                    : static_cast<std::int64_t>(v);
}

}  // namespace tsf::import
