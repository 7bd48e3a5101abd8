#include "tsf/import/dicom_pixel_reader.h"

#include <dcmtk/dcmdata/dcdeftag.h>
#include <dcmtk/dcmdata/dcfilefo.h>
#include <gdcmTrace.h>
#include <itkGDCMImageIO.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <mutex>
#include <new>
#include <sstream>

#include "compressed_frame_header.h"
#include "image_buffers.h"
#include "native_pixel_data.h"
#include "tsf/common/error.h"
#include "tsf/import/imaging_library_setup.h"

namespace tsf::import {
namespace {

/// While alive, what the codecs print goes to memory instead of the terminal: C stdio's `stderr`
/// stream (libjpeg's warnings, OpenJPEG's errors as GDCM forwards them) and GDCM's warning and
/// error trace. Only the `stderr` variable is swapped (glibc allows it), never file descriptor 2:
/// sanitizer reports, std::cerr and the log sinks still reach the terminal. GDCM tries 12-bit
/// JPEG with its 8-bit libjpeg first ("Unsupported JPEG data precision 12") before the 12-bit
/// one decodes it: that message is noise; others tell of damaged data (codec_damage). Used only
/// while codec_mutex() is held, or in a decoder process of one thread.
class CodecDiagnostics {
 public:
  CodecDiagnostics() {
    gdcm::Trace::SetWarningStream(trace_);
    gdcm::Trace::SetErrorStream(trace_);
    gdcm::Trace::SetWarning(true);
    gdcm::Trace::SetError(true);
    std::fflush(stderr);
    memory_ = open_memstream(&buffer_, &size_);
    if (memory_) {
      saved_ = stderr;
      stderr = memory_;
    }
  }
  ~CodecDiagnostics() {
    restore();
    std::free(buffer_);
  }
  CodecDiagnostics(const CodecDiagnostics&) = delete;
  CodecDiagnostics& operator=(const CodecDiagnostics&) = delete;

  /// Everything printed so far (ends the capture).
  std::string text() {
    restore();
    return std::string(buffer_ ? buffer_ : "", size_) + trace_.str();
  }

 private:
  void restore() {
    if (restored_) return;
    restored_ = true;
    if (memory_) {
      std::fflush(memory_);
      stderr = saved_;
      std::fclose(memory_);
      memory_ = nullptr;
    }
    gdcm::Trace::SetWarning(false);
    gdcm::Trace::SetError(false);
    gdcm::Trace::SetWarningStream(std::cerr);
    gdcm::Trace::SetErrorStream(std::cerr);
  }

  std::ostringstream trace_;
  FILE* memory_ = nullptr;
  FILE* saved_ = nullptr;
  char* buffer_ = nullptr;
  std::size_t size_ = 0;
  bool restored_ = false;
};

/// Codecs of third-party libraries run one at a time in this process (GDCM's codecs and the
/// stderr capture are not made for threads); decoder processes each run one anyway.
std::mutex& codec_mutex() {
  static std::mutex m;
  return m;
}

/// The first line of `diagnostics` that tells of damaged data from a decode that succeeded:
/// libjpeg's warnings ("Corrupt JPEG data: ...", "Premature end of JPEG file"), anything
/// OpenJPEG reported. "" when there is none.
std::string codec_damage(const std::string& diagnostics) {
  static const char* const kSigns[] = {"Corrupt JPEG data",
                                       "Premature end of JPEG",
                                       "Invalid SOS parameters",
                                       "Inconsistent progression",
                                       "too few scanlines",
                                       "Bogus",
                                       "openjpeg",
                                       "Tile part",
                                       "tile part",
                                       "Stream too short",
                                       "Expected EOC",
                                       "not enough data"};
  std::istringstream lines(diagnostics);
  std::string line;
  while (std::getline(lines, line))
    for (const char* sign : kSigns)
      if (line.find(sign) != std::string::npos) return line;
  return "";
}

/// The codec lines of `diagnostics` worth showing with a decoder's failure, at most 3. Only lines
/// about the codestream are kept: GDCM's other warnings can quote attribute values, and no
/// patient name or ID may reach a message (import.md, "Privacy").
std::string diagnostics_summary(const std::string& diagnostics) {
  static const char* const kCodecWords[] = {"JPEG", "jpeg",   "openjpeg", "Tile",    "tile",
                                            "RLE",  "stream", "decode",   "Huffman", "marker"};
  std::istringstream lines(diagnostics);
  std::string line, out;
  int kept = 0;
  while (std::getline(lines, line) && kept < 3) {
    if (line.empty() || line.rfind("Warning: In ", 0) == 0 || line.rfind("Error: In ", 0) == 0 ||
        line.find("Unsupported JPEG data precision") != std::string::npos || line.size() > 200)
      continue;
    bool codec = false;
    for (const char* w : kCodecWords) codec = codec || line.find(w) != std::string::npos;
    if (!codec) continue;
    out += (out.empty() ? "" : "; ") + line;
    ++kept;
  }
  return out;
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

/// GDCM's decode of an encapsulated file into `out`: each frame's codestream is checked whole
/// first, the decoder's messages are read after it.
DecodedFrameValues decode_compressed_frames(const DicomFileInfo& info, float* out) {
  if (has_checked_frame_header(info.transfer_syntax_uid)) {
    // The structure of every frame first: what a decoder would turn into wrong pixels.
    const ExpectedFrame expected{info.rows, info.columns, info.samples_per_pixel,
                                 info.bits_allocated, info.bits_stored};
    const std::vector<std::vector<std::uint8_t>> streams = read_frame_codestreams(info);
    for (std::size_t f = 0; f < streams.size(); ++f) {
      const std::string problem = check_frame_codestream(
          info.transfer_syntax_uid, streams[f].data(), streams[f].size(), expected);
      if (!problem.empty())
        throw Error(where(info) + ": frame " + std::to_string(f + 1) + " is damaged: " + problem);
    }
  }
  std::lock_guard<std::mutex> lock(codec_mutex());
  CodecDiagnostics diagnostics;
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
    const std::string said = diagnostics_summary(diagnostics.text());
    throw Error("cannot decode the pixel data of " + where(info) + ": " + e.GetDescription() +
                (said.empty() ? std::string() : " (the decoder said: " + said + ")"));
  } catch (const std::bad_alloc&) {
    throw Error("not enough memory to decode " + where(info));
  }
  const std::string damage = codec_damage(diagnostics.text());
  if (!damage.empty())
    throw Error(where(info) + ": the decoder reported damaged data (" + damage +
                "): refused rather than imported with wrong pixels");

  if (!convert_to_float(io->GetComponentType(), buffer.data(), n, out))
    throw Error(where(info) + ": GDCM decoded an unsupported component type " +
                itk::ImageIOBase::GetComponentTypeAsString(io->GetComponentType()));

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

  return result;
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
  DecodedFrameValues result = info.pixel_data_encapsulated ? decode_compressed_frames(info, out)
                                                           : decode_native_frames(info, out);
  const std::size_t n = static_cast<std::size_t>(info.columns) * info.rows * info.number_of_frames;
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
