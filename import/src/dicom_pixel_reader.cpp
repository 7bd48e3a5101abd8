#include "tsf/import/dicom_pixel_reader.h"

#include <dcmtk/dcmdata/dcdeftag.h>
#include <dcmtk/dcmdata/dcfilefo.h>
#include <itkGDCMImageIO.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <mutex>
#include <new>
#include <optional>

#include "tsf/common/error.h"
#include "tsf/import/imaging_library_setup.h"

namespace tsf::import {
namespace {

template <typename T>
void convert(const void* src, std::size_t n, float* out) {
  const T* s = static_cast<const T*>(src);
  for (std::size_t i = 0; i < n; ++i) out[i] = static_cast<float>(s[i]);
}

/// While alive, C stdio's `stderr` stream points at /dev/null. GDCM tries JPEG data with its
/// 8-bit libjpeg first; for 12-bit data that libjpeg prints "Unsupported JPEG data precision 12"
/// with fprintf(stderr, ...) before GDCM retries with the 12-bit one, which decodes correctly.
/// The message would only confuse users. Only the `stderr` variable is swapped (glibc allows
/// it), never file descriptor 2: sanitizer reports, std::cerr and the log sinks (which captured
/// the stream earlier) still reach the terminal. Reference counted across threads; used only
/// around JPEG decoding.
class JpegStderrSilence {
 public:
  JpegStderrSilence() {
    std::lock_guard<std::mutex> lock(mutex());
    if (depth()++ > 0) return;
    static FILE* const null_stream = std::fopen("/dev/null", "we");
    if (!null_stream) return;
    std::fflush(stderr);
    saved() = stderr;
    stderr = null_stream;
  }
  ~JpegStderrSilence() {
    std::lock_guard<std::mutex> lock(mutex());
    if (--depth() > 0) return;
    if (saved()) {
      std::fflush(stderr);
      stderr = saved();
      saved() = nullptr;
    }
  }
  JpegStderrSilence(const JpegStderrSilence&) = delete;
  JpegStderrSilence& operator=(const JpegStderrSilence&) = delete;

 private:
  static std::mutex& mutex() {
    static std::mutex m;
    return m;
  }
  static int& depth() {
    static int d = 0;
    return d;
  }
  static FILE*& saved() {
    static FILE* stream = nullptr;
    return stream;
  }
};

/// JPEG baseline/extended/lossless transfer syntaxes (1.2.840.10008.1.2.4.50 - .70).
bool is_libjpeg_syntax(const std::string& uid) {
  const std::string prefix = "1.2.840.10008.1.2.4.";
  if (uid.rfind(prefix, 0) != 0) return false;
  const int process = std::atoi(uid.c_str() + prefix.size());
  return process >= 50 && process <= 70;
}

std::string where(const DicomFileInfo& info) {
  return "'" + info.path.string() + "' (" + dicom_uid_name(info.transfer_syntax_uid) + ")";
}

/// The Modality LUT of `info`, applied to stored values in `values` (PS3.3 C.11.1).
void apply_modality_lut(const DicomFileInfo& info, float* values, std::size_t n,
                        DecodedFrameValues& result) {
  DcmFileFormat file;
  if (file.loadFile(info.path.c_str()).bad())
    throw Error("cannot re-read " + where(info) + " for its Modality LUT");
  DcmItem* lut = nullptr;
  if (file.getDataset()->findAndGetSequenceItem(DCM_ModalityLUTSequence, lut, 0).bad() || !lut)
    throw Error(where(info) + ": Modality LUT Sequence (0028,3000) has no item");
  Uint16 descriptor[3] = {0, 0, 0};
  for (unsigned long i = 0; i < 3; ++i)
    if (lut->findAndGetUint16(DCM_LUTDescriptor, descriptor[i], i).bad())
      throw Error(where(info) + ": Modality LUT Descriptor (0028,3002) needs 3 values");
  const long entries = descriptor[0] == 0 ? 65536 : descriptor[0];
  const long first = info.pixel_representation == 1
                         ? static_cast<long>(static_cast<std::int16_t>(descriptor[1]))
                         : static_cast<long>(descriptor[1]);
  // At most 65536 entries of 16 bits: a larger declared length would be allocated on reading.
  DcmElement* lut_data = nullptr;
  if (lut->findAndGetElement(DCM_LUTData, lut_data).bad() || !lut_data ||
      lut_data->getLength() > 2u * 65536u)
    throw Error(where(info) +
                ": Modality LUT Data (0028,3006) is missing or longer than 65536 "
                "entries");
  const Uint16* data = nullptr;
  unsigned long count = 0;
  if (lut->findAndGetUint16Array(DCM_LUTData, data, &count).bad() || !data ||
      count < static_cast<unsigned long>(entries))
    throw Error(where(info) + ": Modality LUT Data (0028,3006) holds " + std::to_string(count) +
                " entries, the descriptor declares " + std::to_string(entries));
  OFString type;
  if (lut->findAndGetOFString(DCM_ModalityLUTType, type).good())
    result.modality_lut_type = type.c_str();
  for (std::size_t i = 0; i < n; ++i) {
    const long index = std::clamp(std::lround(values[i]) - first, 0L, entries - 1);
    values[i] = static_cast<float>(data[index]);
  }
  result.modality_lut_applied = true;
}

}  // namespace

DecodedFrameValues decode_dicom_frames(const DicomFileInfo& info, float* out) {
  setup_imaging_libraries();
  if (!info.has_pixel_data) throw Error(where(info) + " has no pixel data");
  if (info.samples_per_pixel != 1)
    throw Error(where(info) + " has " + std::to_string(info.samples_per_pixel) +
                " samples per pixel, expected 1 (grey-scale)");
  const std::uint64_t declared = info.decoded_bytes();
  if (!info.pixel_data_encapsulated && info.pixel_data_bytes < declared)
    throw Error(where(info) + ": the pixel data hold " + std::to_string(info.pixel_data_bytes) +
                " bytes but the header declares " + std::to_string(info.columns) + "×" +
                std::to_string(info.rows) + "×" + std::to_string(info.number_of_frames) +
                " pixels of " + std::to_string(info.bits_allocated) + " bits (" +
                std::to_string(declared) + " bytes)");

  std::optional<JpegStderrSilence> silence;
  if (is_libjpeg_syntax(info.transfer_syntax_uid)) silence.emplace();
  auto io = itk::GDCMImageIO::New();
  io->SetFileName(info.path.string());
  io->LoadPrivateTagsOff();
  try {
    io->ReadImageInformation();
  } catch (const itk::ExceptionObject& e) {
    throw Error("cannot read " + where(info) + ": " + e.GetDescription());
  }
  const unsigned nd = io->GetNumberOfDimensions();
  const auto frames_io = nd >= 3 ? io->GetDimensions(2) : 1;
  if (io->GetDimensions(0) != static_cast<itk::SizeValueType>(info.columns) ||
      io->GetDimensions(1) != static_cast<itk::SizeValueType>(info.rows) ||
      frames_io != static_cast<itk::SizeValueType>(info.number_of_frames) ||
      io->GetNumberOfComponents() != 1)
    throw Error(where(info) + ": GDCM sees " + std::to_string(io->GetDimensions(0)) + "×" +
                std::to_string(io->GetDimensions(1)) + "×" + std::to_string(frames_io) + "×" +
                std::to_string(io->GetNumberOfComponents()) + " samples, the header says " +
                std::to_string(info.columns) + "×" + std::to_string(info.rows) + "×" +
                std::to_string(info.number_of_frames) + "×1");
  const std::size_t n = static_cast<std::size_t>(info.columns) * info.rows * info.number_of_frames;
  const std::size_t bytes = n * io->GetComponentSize();
  if (static_cast<std::size_t>(io->GetImageSizeInBytes()) != bytes)
    throw Error(where(info) + ": GDCM would decode " + std::to_string(io->GetImageSizeInBytes()) +
                " bytes, expected " + std::to_string(bytes));

  std::vector<unsigned char> buffer;
  try {
    buffer.resize(bytes);
    io->Read(buffer.data());
  } catch (const itk::ExceptionObject& e) {
    throw Error("cannot decode the pixel data of " + where(info) + ": " + e.GetDescription());
  } catch (const std::bad_alloc&) {
    throw Error("not enough memory to decode " + where(info));
  }

  using Component = itk::CommonEnums::IOComponent;
  switch (io->GetComponentType()) {
    case Component::UCHAR:
      convert<unsigned char>(buffer.data(), n, out);
      break;
    case Component::CHAR:
      convert<signed char>(buffer.data(), n, out);
      break;
    case Component::USHORT:
      convert<std::uint16_t>(buffer.data(), n, out);
      break;
    case Component::SHORT:
      convert<std::int16_t>(buffer.data(), n, out);
      break;
    case Component::UINT:
      convert<std::uint32_t>(buffer.data(), n, out);
      break;
    case Component::INT:
      convert<std::int32_t>(buffer.data(), n, out);
      break;
    case Component::ULONG:
      convert<unsigned long>(buffer.data(), n, out);
      break;
    case Component::LONG:
      convert<long>(buffer.data(), n, out);
      break;
    case Component::FLOAT:
      convert<float>(buffer.data(), n, out);
      break;
    case Component::DOUBLE:
      convert<double>(buffer.data(), n, out);
      break;
    default:
      throw Error(where(info) + ": GDCM decoded an unsupported component type " +
                  itk::ImageIOBase::GetComponentTypeAsString(io->GetComponentType()));
  }

  DecodedFrameValues result;
  result.slope = io->GetRescaleSlope();
  result.intercept = io->GetRescaleIntercept();
  if (!(result.slope != 0) || !std::isfinite(result.slope) || !std::isfinite(result.intercept))
    throw Error(where(info) + ": rescale slope " + std::to_string(result.slope) + " / intercept " +
                std::to_string(result.intercept) + " cannot map values");

  // Frames whose own modality transform differs from what GDCM applied (enhanced objects with
  // per-frame Pixel Value Transformation): stored = (v − b0)/m0, value = stored·m + b.
  const std::size_t plane = static_cast<std::size_t>(info.columns) * info.rows;
  for (int f = 0; f < info.number_of_frames; ++f) {
    const DicomFrameInfo& fr = info.frames.at(static_cast<std::size_t>(f));
    const double m = fr.has_rescale ? fr.rescale_slope : 1.0;
    const double b = fr.has_rescale ? fr.rescale_intercept : 0.0;
    if (std::abs(m - result.slope) <= 1e-9 * std::abs(m) && std::abs(b - result.intercept) <= 1e-9)
      continue;
    if (!(m != 0) || !std::isfinite(m) || !std::isfinite(b))
      throw Error(where(info) + ": frame " + std::to_string(f + 1) + " has rescale slope " +
                  std::to_string(m) + ", intercept " + std::to_string(b));
    float* v = out + static_cast<std::size_t>(f) * plane;
    for (std::size_t i = 0; i < plane; ++i)
      v[i] =
          static_cast<float>((static_cast<double>(v[i]) - result.intercept) / result.slope * m + b);
    ++result.frames_remapped;
  }

  if (info.has_modality_lut) {
    if (result.slope != 1.0 || result.intercept != 0.0 || result.frames_remapped > 0)
      throw Error(where(info) +
                  " has both a Modality LUT Sequence and a rescale slope/intercept: ambiguous "
                  "modality transform");
    apply_modality_lut(info, out, n, result);
  }
  return result;
}

std::vector<float> decode_dicom_file(const std::filesystem::path& path, DicomFileInfo* info_out) {
  DicomFileInfo info = read_dicom_file_info(path);
  if (info.kind != DicomObjectKind::image && info.kind != DicomObjectKind::localizer)
    throw Error("'" + path.string() + "' is not a usable image: " + info.skip_reason);
  constexpr std::uint64_t kMaxValues = std::uint64_t{1} << 30;
  if (info.decoded_bytes() / std::max(1, info.bits_allocated / 8) > kMaxValues)
    throw Error("'" + path.string() + "' declares more than 2^30 pixels: refused");
  std::vector<float> values(static_cast<std::size_t>(info.columns) * info.rows *
                            info.number_of_frames);
  decode_dicom_frames(info, values.data());
  if (info_out) *info_out = std::move(info);
  return values;
}

}  // namespace tsf::import
