#include "native_pixel_data.h"

#include <dcmtk/dcmdata/dcdeftag.h>
#include <dcmtk/dcmdata/dcfcache.h>
#include <dcmtk/dcmdata/dcfilefo.h>
#include <dcmtk/dcmdata/dcxfer.h>

#include <cmath>
#include <cstring>
#include <new>
#include <vector>

#include "tsf/common/error.h"

namespace tsf::import {
namespace {

/// Values longer than this stay on disk while the header is parsed (as in the header pass).
constexpr Uint32 kMaxHeaderValueLength = 4096;

std::string where(const DicomFileInfo& info) {
  return "'" + info.path.string() + "' (" + dicom_uid_name(info.transfer_syntax_uid) + ")";
}

/// Converts `n` samples of type T (as read, machine byte order) to modality values.
template <typename T>
void convert_frame(const unsigned char* raw, std::size_t n, const DicomFileInfo& info,
                   bool swap_halves, double slope, double intercept, float* out) {
  const bool is_signed = info.pixel_representation == 1;
  const int bits_stored = info.bits_stored;
  const int high_bit = info.high_bit;
  const bool identity = slope == 1.0 && intercept == 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    T sample;
    std::memcpy(&sample, raw + i * sizeof(T), sizeof(T));
    std::uint32_t bits = static_cast<std::uint32_t>(sample);
    if (swap_halves) bits = (bits >> 16) | (bits << 16);
    const std::int64_t v = stored_sample_value(bits, bits_stored, high_bit, is_signed);
    out[i] = identity ? static_cast<float>(v)
                      : static_cast<float>(static_cast<double>(v) * slope + intercept);
  }
}

}  // namespace

DecodedFrameValues decode_native_frames(const DicomFileInfo& info, float* out) {
  const int ba = info.bits_allocated;
  if (ba != 8 && ba != 16 && ba != 32)
    throw Error(where(info) + ": BitsAllocated " + std::to_string(ba) +
                " (expected 8, 16 or 32 bits per sample)");
  if (info.bits_stored < 1 || info.bits_stored > ba || info.high_bit < info.bits_stored - 1 ||
      info.high_bit >= ba)
    throw Error(where(info) + ": BitsStored " + std::to_string(info.bits_stored) + " and HighBit " +
                std::to_string(info.high_bit) + " do not fit BitsAllocated " + std::to_string(ba));
  if (info.frames.size() != static_cast<std::size_t>(info.number_of_frames))
    throw Error(where(info) + ": the header's frames were not read");

  DcmFileFormat file;
  if (file.loadFile(info.path.c_str(), EXS_Unknown, EGL_noChange, kMaxHeaderValueLength,
                    ERM_autoDetect)
          .bad())
    throw Error("cannot re-read " + where(info) + " for its pixel data");
  DcmElement* pixel_data = nullptr;
  if (file.getDataset()->findAndGetElement(DCM_PixelData, pixel_data).bad() || !pixel_data)
    throw Error(where(info) + " has no pixel data");
  const std::uint64_t frame_samples = static_cast<std::uint64_t>(info.columns) * info.rows;
  const std::uint64_t frame_bytes = frame_samples * static_cast<std::uint64_t>(ba / 8);
  const std::uint64_t total = frame_bytes * static_cast<std::uint64_t>(info.number_of_frames);
  if (std::uint64_t{pixel_data->getLength()} < total)
    throw Error(where(info) + ": the pixel data hold " + std::to_string(pixel_data->getLength()) +
                " bytes but the header declares " + std::to_string(total));
  // OW values come in the machine's byte order by 16-bit words; a 32-bit sample of a big-endian
  // file then has its two halves swapped.
  const bool swap_halves =
      ba == 32 && DcmXfer(file.getDataset()->getOriginalXfer()).getByteOrder() == EBO_BigEndian;

  DecodedFrameValues result;
  std::vector<unsigned char> raw;
  try {
    raw.resize(static_cast<std::size_t>(frame_bytes));
  } catch (const std::bad_alloc&) {
    throw Error("not enough memory to decode " + where(info));
  }
  DcmFileCache cache;
  for (int f = 0; f < info.number_of_frames; ++f) {
    if (pixel_data
            ->getPartialValue(raw.data(), static_cast<Uint32>(frame_bytes * f),
                              static_cast<Uint32>(frame_bytes), &cache, gLocalByteOrder)
            .bad())
      throw Error("cannot read frame " + std::to_string(f + 1) + " of the pixel data of " +
                  where(info));
    const DicomFrameInfo& fr = info.frames[static_cast<std::size_t>(f)];
    const double m = fr.has_rescale ? fr.rescale_slope : 1.0;
    const double b = fr.has_rescale ? fr.rescale_intercept : 0.0;
    if (!(m != 0) || !std::isfinite(m) || !std::isfinite(b))
      throw Error(where(info) + ": frame " + std::to_string(f + 1) + " has rescale slope " +
                  std::to_string(m) + ", intercept " + std::to_string(b));
    if (f == 0) {
      result.slope = m;
      result.intercept = b;
    } else if (m != result.slope || b != result.intercept) {
      ++result.frames_remapped;
    }
    float* o = out + static_cast<std::size_t>(f) * frame_samples;
    const std::size_t n = static_cast<std::size_t>(frame_samples);
    if (ba == 8)
      convert_frame<std::uint8_t>(raw.data(), n, info, false, m, b, o);
    else if (ba == 16)
      convert_frame<std::uint16_t>(raw.data(), n, info, false, m, b, o);
    else
      convert_frame<std::uint32_t>(raw.data(), n, info, swap_halves, m, b, o);
  }
  return result;
}

}  // namespace tsf::import
