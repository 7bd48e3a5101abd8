#include "tsf/import/dicom_file_info.h"

#include <dcmtk/dcmdata/dcdeftag.h>
#include <dcmtk/dcmdata/dcfilefo.h>
#include <dcmtk/dcmdata/dcmetinf.h>
#include <dcmtk/dcmdata/dcpixel.h>
#include <dcmtk/dcmdata/dcpixseq.h>
#include <dcmtk/dcmdata/dcpxitem.h>
#include <dcmtk/dcmdata/dcsequen.h>
#include <dcmtk/dcmdata/dcstack.h>
#include <dcmtk/dcmdata/dcuid.h>
#include <dcmtk/dcmdata/dcxfer.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <vector>

#include "compressed_frame_header.h"
#include "dicom_nesting.h"
#include "geometry_limits.h"
#include "tsf/common/error.h"
#include "tsf/import/imaging_library_setup.h"

namespace tsf::import {
namespace fs = std::filesystem;

namespace {

/// Values longer than this stay on disk while the header is parsed (pixel data, LUTs, ...).
constexpr Uint32 kMaxHeaderValueLength = 4096;
/// More frames than this in one object is not a CT: refuse before sizing per-frame tables.
constexpr long kMaxFrames = 65536;
constexpr const char* kMediaStorageDirectoryUid = "1.2.840.10008.1.3.10";

std::string trim(const std::string& s) {
  const auto b = s.find_first_not_of(" \t\r\n");
  if (b == std::string::npos) return {};
  const auto e = s.find_last_not_of(" \t\r\n");
  return s.substr(b, e - b + 1);
}

/// Whether `tag` is in `item` with a value short enough to be a header attribute. DCMTK leaves
/// longer values on disk and reads them when asked, allocating the declared length: a damaged
/// file declaring 4 GB for a UID would cost 4 GB (import.md, "Limits and safety"). The length
/// field as read is compared: getLength() of a string element loads the value to measure it.
bool has_header_value(DcmItem& item, const DcmTagKey& tag) {
  DcmElement* element = nullptr;
  return item.findAndGetElement(tag, element).good() && element &&
         element->getLengthField() <= kMaxHeaderValueLength;
}

std::string get_string(DcmItem& item, const DcmTagKey& tag) {
  OFString value;
  if (has_header_value(item, tag) && item.findAndGetOFStringArray(tag, value).good())
    return trim(value.c_str());
  return {};
}

bool get_double(DcmItem& item, const DcmTagKey& tag, double& out, unsigned long pos = 0) {
  if (!has_header_value(item, tag)) return false;
  Float64 f = 0;
  if (item.findAndGetFloat64(tag, f, pos).good() && std::isfinite(f)) {
    out = f;
    return true;
  }
  OFString s;
  if (item.findAndGetOFString(tag, s, pos).good()) {
    const std::string t = trim(s.c_str());
    char* end = nullptr;
    const double v = std::strtod(t.c_str(), &end);
    if (!t.empty() && end && *end == '\0' && std::isfinite(v)) {
      out = v;
      return true;
    }
  }
  return false;
}

/// A value that is present but cannot be used: its tag, its text and what was expected. Thrown by
/// get_checked_double, caught per file (the file is then damaged; import.md, "What is skipped,
/// refused and repaired").
struct InvalidValue : Error {
  using Error::Error;
};

/// The accepted values of an attribute used for geometry or rescale.
struct ValueRange {
  double lo = -HUGE_VAL, hi = HUGE_VAL;
  bool lo_open = false;
  const char* unit = "";
};
constexpr ValueRange kAnyFinite{};
constexpr ValueRange kPositionMm{-kMaxCoordinateMm, kMaxCoordinateMm, false, " mm"};
constexpr ValueRange kPixelSpacingMm{0, kMaxSpacingMm, true, " mm"};

/// Value `pos` of `tag` (DS, IS or FD) used for geometry or rescale: false when the attribute
/// is absent; InvalidValue when it is present but empty, short of values, not a number, not
/// finite or outside `range` (one unparsable RescaleIntercept must not become 0).
bool get_checked_double(DcmItem& item, const DcmTagKey& tag, double& out, unsigned long pos,
                        const ValueRange& range) {
  DcmElement* element = nullptr;
  if (item.findAndGetElement(tag, element).bad() || !element) return false;
  const std::string name = std::string(DcmTag(tag).getTagName()) + " " + tag.toString().c_str() +
                           (pos > 0 || element->getVM() > 1 ? "[" + std::to_string(pos) + "]" : "");
  if (element->getLengthField() > kMaxHeaderValueLength)
    throw InvalidValue(name + " declares " + std::to_string(element->getLengthField()) +
                       " bytes: expected a decimal number");
  OFString text;
  const std::string t = element->getOFString(text, pos).good() ? trim(text.c_str()) : "";
  std::ostringstream expected;
  if (std::isinf(range.lo) && std::isinf(range.hi))
    expected << "expected a finite decimal number";
  else
    expected << "expected a number in " << (range.lo_open ? "(" : "[") << range.lo << ", "
             << range.hi << "]" << range.unit;
  if (t.empty())
    throw InvalidValue(name + " is empty or missing (" + std::to_string(element->getVM()) +
                       " values): " + expected.str());
  char* end = nullptr;
  const double v = std::strtod(t.c_str(), &end);
  const bool in_range = (range.lo_open ? v > range.lo : v >= range.lo) && v <= range.hi;
  if (!end || *end != '\0' || !std::isfinite(v) || !in_range)
    throw InvalidValue(name + " is '" + t + "': " + expected.str());
  out = v;
  return true;
}

bool get_checked_vec3(DcmItem& item, const DcmTagKey& tag, Vec3d& out, unsigned long first,
                      const ValueRange& range) {
  for (int a = 0; a < 3; ++a)
    if (!get_checked_double(item, tag, out[a], first + static_cast<unsigned long>(a), range))
      return false;
  return true;
}

bool get_long(DcmItem& item, const DcmTagKey& tag, long& out) {
  if (!has_header_value(item, tag)) return false;
  long v = 0;
  if (item.findAndGetLongInt(tag, v).good()) {
    out = v;
    return true;
  }
  double d = 0;
  if (get_double(item, tag, d) && std::abs(d) < 2e9 && d == std::floor(d)) {
    out = static_cast<long>(d);
    return true;
  }
  return false;
}

DcmItem* sequence_item(DcmItem* item, const DcmTagKey& sequence) {
  if (!item) return nullptr;
  DcmItem* found = nullptr;
  if (item->findAndGetSequenceItem(sequence, found, 0).good()) return found;
  return nullptr;
}

/// The item of functional group `sequence` for one frame: per-frame first, then shared.
DcmItem* functional_group(DcmItem* per_frame, DcmItem* shared, const DcmTagKey& sequence) {
  if (DcmItem* it = sequence_item(per_frame, sequence)) return it;
  return sequence_item(shared, sequence);
}

void read_plane_attributes(DcmItem& position_item, DcmItem& orientation_item, DcmItem& spacing_item,
                           DcmItem& rescale_item, DicomFrameInfo& f) {
  f.has_position =
      get_checked_vec3(position_item, DCM_ImagePositionPatient, f.position, 0, kPositionMm);
  f.has_orientation =
      get_checked_vec3(orientation_item, DCM_ImageOrientationPatient, f.row, 0, kAnyFinite) &&
      get_checked_vec3(orientation_item, DCM_ImageOrientationPatient, f.column, 3, kAnyFinite);
  f.has_pixel_spacing = get_checked_double(spacing_item, DCM_PixelSpacing, f.spacing_between_rows,
                                           0, kPixelSpacingMm) &&
                        get_checked_double(spacing_item, DCM_PixelSpacing,
                                           f.spacing_between_columns, 1, kPixelSpacingMm);
  double slope = 1, intercept = 0;
  const bool has_slope = get_checked_double(rescale_item, DCM_RescaleSlope, slope, 0, kAnyFinite);
  const bool has_intercept =
      get_checked_double(rescale_item, DCM_RescaleIntercept, intercept, 0, kAnyFinite);
  f.has_rescale = has_slope || has_intercept;
  f.rescale_slope = has_slope ? slope : 1.0;
  f.rescale_intercept = has_intercept ? intercept : 0.0;
}

bool image_type_is_localizer(const std::string& image_type) {
  std::string upper = image_type;
  std::transform(upper.begin(), upper.end(), upper.begin(),
                 [](unsigned char c) { return static_cast<char>(std::toupper(c)); });
  for (const char* word : {"LOCALIZER", "SCOUT", "TOPOGRAM", "SCANOGRAM", "SURVIEW"})
    if (upper.find(word) != std::string::npos) return true;
  return false;
}

void classify_image(DcmDataset& ds, DicomFileInfo& info) {
  long v = 0;
  info.rows = get_long(ds, DCM_Rows, v) ? static_cast<int>(v) : 0;
  info.columns = get_long(ds, DCM_Columns, v) ? static_cast<int>(v) : 0;
  info.samples_per_pixel = get_long(ds, DCM_SamplesPerPixel, v) ? static_cast<int>(v) : 1;
  info.bits_allocated = get_long(ds, DCM_BitsAllocated, v) ? static_cast<int>(v) : 0;
  info.bits_stored = get_long(ds, DCM_BitsStored, v) ? static_cast<int>(v) : info.bits_allocated;
  info.high_bit = get_long(ds, DCM_HighBit, v) ? static_cast<int>(v) : info.bits_stored - 1;
  info.pixel_representation = get_long(ds, DCM_PixelRepresentation, v) ? static_cast<int>(v) : 0;
  long frames = 1;
  if (get_long(ds, DCM_NumberOfFrames, frames) && frames == 0) frames = 1;
  info.photometric_interpretation = get_string(ds, DCM_PhotometricInterpretation);

  if (info.rows <= 0 || info.columns <= 0) {
    info.kind = DicomObjectKind::unsupported;
    info.skip_reason = "image of " + std::to_string(info.columns) + "×" +
                       std::to_string(info.rows) + " pixels (Rows/Columns missing or zero)";
    return;
  }
  if (frames < 1 || frames > kMaxFrames) {
    info.kind = DicomObjectKind::unsupported;
    info.skip_reason = "NumberOfFrames " + std::to_string(frames) + " is out of range (1.." +
                       std::to_string(kMaxFrames) + ")";
    return;
  }
  info.number_of_frames = static_cast<int>(frames);
  if (info.samples_per_pixel != 1) {
    info.kind = DicomObjectKind::unsupported;
    info.skip_reason = "colour image (" + std::to_string(info.samples_per_pixel) +
                       " samples per pixel, " + info.photometric_interpretation +
                       "): not a CT volume";
    return;
  }
  if (info.photometric_interpretation.rfind("PALETTE", 0) == 0) {
    info.kind = DicomObjectKind::unsupported;
    info.skip_reason = "palette-colour image: not a CT volume";
    return;
  }
  if (info.bits_allocated != 8 && info.bits_allocated != 16 && info.bits_allocated != 32) {
    info.kind = DicomObjectKind::unsupported;
    info.skip_reason = "BitsAllocated " + std::to_string(info.bits_allocated) +
                       " (expected 8, 16 or 32 bits per sample)";
    return;
  }
  if (info.bits_stored < 1 || info.bits_stored > info.bits_allocated) {
    info.kind = DicomObjectKind::unsupported;
    info.skip_reason = "BitsStored " + std::to_string(info.bits_stored) + " with BitsAllocated " +
                       std::to_string(info.bits_allocated);
    return;
  }
  if (info.high_bit < info.bits_stored - 1 || info.high_bit >= info.bits_allocated) {
    info.kind = DicomObjectKind::unsupported;
    info.skip_reason = "HighBit " + std::to_string(info.high_bit) + " with BitsStored " +
                       std::to_string(info.bits_stored) + " and BitsAllocated " +
                       std::to_string(info.bits_allocated);
    return;
  }
  if (info.pixel_representation != 0 && info.pixel_representation != 1) {
    info.kind = DicomObjectKind::unsupported;
    info.skip_reason = "PixelRepresentation " + std::to_string(info.pixel_representation) +
                       " (expected 0, unsigned, or 1, signed)";
    return;
  }
  if (image_type_is_localizer(info.image_type)) {
    info.kind = DicomObjectKind::localizer;
    info.skip_reason = "localizer (ImageType " + info.image_type + ")";
    return;
  }
  info.kind = DicomObjectKind::image;
}

void read_frames(DcmDataset& ds, DicomFileInfo& info) {
  DcmItem* shared = sequence_item(&ds, DCM_SharedFunctionalGroupsSequence);
  DcmSequenceOfItems* per_frame_seq = nullptr;
  ds.findAndGetSequence(DCM_PerFrameFunctionalGroupsSequence, per_frame_seq);
  info.enhanced = shared != nullptr || per_frame_seq != nullptr;
  info.frames.assign(static_cast<std::size_t>(info.number_of_frames), DicomFrameInfo{});

  if (!info.enhanced) {
    DicomFrameInfo top;
    read_plane_attributes(ds, ds, ds, ds, top);
    // A classic multi-frame image (e.g. NM, old US) has one position for all frames: only the
    // first frame is placed; the series analysis refuses it as a volume.
    info.frames[0] = top;
    for (std::size_t f = 1; f < info.frames.size(); ++f) {
      info.frames[f] = top;
      info.frames[f].has_position = false;
    }
    return;
  }
  if (per_frame_seq && per_frame_seq->card() != static_cast<unsigned long>(info.number_of_frames)) {
    info.kind = DicomObjectKind::unsupported;
    info.skip_reason = "PerFrameFunctionalGroupsSequence has " +
                       std::to_string(per_frame_seq->card()) + " items for " +
                       std::to_string(info.number_of_frames) + " frames";
    return;
  }
  DicomFrameInfo top;
  read_plane_attributes(ds, ds, ds, ds, top);
  for (int f = 0; f < info.number_of_frames; ++f) {
    DcmItem* pf = per_frame_seq ? per_frame_seq->getItem(static_cast<unsigned long>(f)) : nullptr;
    DcmItem* pos = functional_group(pf, shared, DCM_PlanePositionSequence);
    DcmItem* ori = functional_group(pf, shared, DCM_PlaneOrientationSequence);
    DcmItem* mea = functional_group(pf, shared, DCM_PixelMeasuresSequence);
    DcmItem* val = functional_group(pf, shared, DCM_PixelValueTransformationSequence);
    DicomFrameInfo fi = top;  // top-level values are the fallback for absent groups
    DicomFrameInfo g;
    try {
      read_plane_attributes(pos ? *pos : ds, ori ? *ori : ds, mea ? *mea : ds, val ? *val : ds, g);
    } catch (const InvalidValue& e) {
      throw InvalidValue("frame " + std::to_string(f + 1) + ": " + e.what());
    }
    if (pos) fi.has_position = g.has_position, fi.position = g.position;
    if (ori) fi.has_orientation = g.has_orientation, fi.row = g.row, fi.column = g.column;
    if (mea && g.has_pixel_spacing)
      fi.has_pixel_spacing = true, fi.spacing_between_rows = g.spacing_between_rows,
      fi.spacing_between_columns = g.spacing_between_columns;
    if (val && g.has_rescale)
      fi.has_rescale = true, fi.rescale_slope = g.rescale_slope,
      fi.rescale_intercept = g.rescale_intercept;
    info.frames[static_cast<std::size_t>(f)] = fi;

    // A frame flagged as a localizer makes the whole object unusable as a volume.
    DcmItem* frame_type = functional_group(pf, shared, DCM_CTImageFrameTypeSequence);
    if (frame_type && image_type_is_localizer(get_string(*frame_type, DCM_FrameType))) {
      info.kind = DicomObjectKind::localizer;
      info.skip_reason =
          "localizer frames (FrameType " + get_string(*frame_type, DCM_FrameType) + ")";
    }
  }
}

/// Whether the last bytes of the pixel data can be read: DCMTK leaves large values on disk, so a
/// file cut short parses fine and fails only here (one small read at the end of the value).
bool pixel_data_is_complete(DcmElement& pixel_data, const DcmXfer& xfer) {
  DcmElement* last = &pixel_data;
  if (xfer.isEncapsulated()) {
    auto* pixel = dynamic_cast<DcmPixelData*>(&pixel_data);
    DcmPixelSequence* sequence = nullptr;
    if (!pixel || pixel->getEncapsulatedRepresentation(xfer.getXfer(), nullptr, sequence).bad() ||
        !sequence || sequence->card() == 0)
      return false;
    DcmPixelItem* item = nullptr;
    if (sequence->getItem(item, sequence->card() - 1).bad() || !item) return false;
    last = item;
  }
  const Uint32 length = last->getLength();
  if (length == 0 || length == DCM_UndefinedLength) return true;
  unsigned char tail[2];
  const Uint32 n = length >= 2 ? 2 : 1;
  return last->getPartialValue(tail, length - n, n).good();
}

/// The first element whose binary value cannot be what its VR says (a length that is not a whole
/// number of US, SS, UL, SL, FL, FD or AT values), or an Image Pixel attribute GDCM reads as US
/// that is not one US: GDCM asserts on both and kills the process, so they are refused first
/// (import.md, "Limits and safety"). "" when there is none.
std::string binary_value_problem(DcmDataset& ds) {
  for (const DcmTagKey& tag :
       {DCM_SamplesPerPixel, DCM_Rows, DCM_Columns, DCM_BitsAllocated, DCM_BitsStored, DCM_HighBit,
        DCM_PixelRepresentation, DCM_PlanarConfiguration}) {
    DcmElement* e = nullptr;
    if (ds.findAndGetElement(tag, e).good() && e &&
        (e->ident() != EVR_US || e->getLengthField() != 2))
      return std::string(DcmTag(tag).getTagName()) + " " + tag.toString().c_str() + " has VR " +
             DcmVR(e->ident()).getVRName() + " and " + std::to_string(e->getLengthField()) +
             " bytes: expected one US value";
  }
  // Attributes GDCM reads with a fixed VR (gdcm::Attribute, in ImageHelper) assert on another:
  // those that place or scale the image must have their standard VR (found by fuzzing).
  static const std::pair<DcmTagKey, DcmEVR> kFixedVr[] = {
      {DCM_ImagePositionPatient, EVR_DS}, {DCM_ImageOrientationPatient, EVR_DS},
      {DCM_PixelSpacing, EVR_DS},         {DCM_RescaleIntercept, EVR_DS},
      {DCM_RescaleSlope, EVR_DS},         {DCM_SliceThickness, EVR_DS},
      {DCM_SpacingBetweenSlices, EVR_DS}, {DCM_NumberOfFrames, EVR_IS},
      {DCM_ImagerPixelSpacing, EVR_DS},   {DCM_NominalScannedPixelSpacing, EVR_DS},
      {DCM_RescaleType, EVR_LO}};
  DcmStack stack;
  while (ds.nextObject(stack, OFTrue).good()) {
    DcmObject* o = stack.top();
    if (!o || !o->isLeaf()) continue;
    for (const auto& [tag, vr] : kFixedVr)
      if (o->getTag() == tag && o->ident() != vr && o->ident() != EVR_UN)
        return std::string(DcmTag(tag).getTagName()) + " " + tag.toString().c_str() + " has VR " +
               DcmVR(o->ident()).getVRName() + ", expected " + DcmVR(vr).getVRName();
    Uint32 unit = 0;
    switch (o->ident()) {
      case EVR_US:
      case EVR_SS:
        unit = 2;
        break;
      case EVR_UL:
      case EVR_SL:
      case EVR_FL:
      case EVR_AT:
        unit = 4;
        break;
      case EVR_FD:
        unit = 8;
        break;
      default:
        break;
    }
    const Uint32 length = o->getLengthField();
    if (unit > 0 && length != DCM_UndefinedLength && length % unit != 0)
      return "element " + std::string(o->getTag().toString().c_str()) + " has VR " +
             DcmVR(o->ident()).getVRName() + " and " + std::to_string(length) +
             " bytes: not a whole number of values";
  }
  return "";
}

/// The fragment (item index in the pixel sequence) where each frame starts: one fragment per
/// frame, or the Basic Offset Table's byte offsets; only frame 1 when neither says. An empty
/// result with `problem` set when the frames cannot all have a fragment.
std::vector<unsigned long> frame_fragments(DcmPixelSequence& sequence, int frames,
                                           std::string& problem) {
  const unsigned long fragments = sequence.card() > 0 ? sequence.card() - 1 : 0;
  if (fragments < static_cast<unsigned long>(frames)) {
    problem = "the pixel data hold " + std::to_string(fragments) +
              " fragments, fewer than the NumberOfFrames " + std::to_string(frames);
    return {};
  }
  std::vector<unsigned long> first(1, 1);
  if (fragments == static_cast<unsigned long>(frames)) {
    for (int f = 1; f < frames; ++f) first.push_back(static_cast<unsigned long>(f) + 1);
    return first;
  }
  DcmPixelItem* table = nullptr;
  if (frames < 2 || sequence.getItem(table, 0).bad() || !table ||
      table->getLength() != 4u * static_cast<Uint32>(frames))
    return first;
  std::vector<Uint8> bytes(table->getLength());
  if (table->getPartialValue(bytes.data(), 0, table->getLength()).bad()) return first;
  // Offsets count bytes from the first fragment's item tag (8 bytes of tag and length each).
  std::uint64_t position = 0;
  unsigned long item = 1;
  for (int f = 1; f < frames; ++f) {
    const std::uint64_t offset =
        std::uint64_t{bytes[4 * f]} | (std::uint64_t{bytes[4 * f + 1]} << 8) |
        (std::uint64_t{bytes[4 * f + 2]} << 16) | (std::uint64_t{bytes[4 * f + 3]} << 24);
    while (position < offset && item <= fragments) {
      DcmPixelItem* fragment = nullptr;
      if (sequence.getItem(fragment, item).bad() || !fragment) return {first.front()};
      position += 8 + std::uint64_t{fragment->getLength()};
      ++item;
    }
    if (position != offset || item > fragments) {
      problem = "the Basic Offset Table's offset " + std::to_string(offset) + " of frame " +
                std::to_string(f + 1) + " is not the start of a fragment";
      return {};
    }
    first.push_back(item);
  }
  return first;
}

/// Compares the codestream header of every frame with the DICOM header (compressed_frame_header.h)
/// and the declared image size with the compressed bytes; "" when all agree, else the first
/// disagreement with its frame. Sets info.pixel_data_bytes to the compressed bytes.
std::string check_compressed_frames(DcmElement& pixel_data, const DcmXfer& xfer,
                                    DicomFileInfo& info) {
  if (!has_checked_frame_header(info.transfer_syntax_uid)) return "";
  auto* pixel = dynamic_cast<DcmPixelData*>(&pixel_data);
  DcmPixelSequence* sequence = nullptr;
  if (!pixel || pixel->getEncapsulatedRepresentation(xfer.getXfer(), nullptr, sequence).bad() ||
      !sequence)
    return "the compressed pixel data have no fragments";
  const unsigned long fragments = sequence->card() > 0 ? sequence->card() - 1 : 0;
  if (one_fragment_per_frame(info.transfer_syntax_uid) &&
      fragments != static_cast<unsigned long>(info.number_of_frames))
    return dicom_uid_name(info.transfer_syntax_uid) +
           " puts each frame in one fragment: the pixel "
           "data hold " +
           std::to_string(fragments) + " fragments for NumberOfFrames " +
           std::to_string(info.number_of_frames);
  std::string problem;
  const std::vector<unsigned long> first =
      frame_fragments(*sequence, info.number_of_frames, problem);
  if (!problem.empty()) return problem;
  std::uint64_t bytes = 0;
  for (unsigned long i = 1; i < sequence->card(); ++i) {
    DcmPixelItem* fragment = nullptr;
    if (sequence->getItem(fragment, i).good() && fragment) bytes += fragment->getLength();
  }
  info.pixel_data_bytes = bytes;
  const std::string image_size = std::to_string(info.columns) + "×" + std::to_string(info.rows) +
                                 "×" + std::to_string(info.number_of_frames);
  const double per_byte = max_samples_per_compressed_byte(info.transfer_syntax_uid);
  const double samples =
      static_cast<double>(info.decoded_bytes()) / std::max(1, (info.bits_allocated + 7) / 8);
  if (per_byte > 0 && samples > per_byte * static_cast<double>(bytes))
    return "the compressed pixel data hold " + std::to_string(bytes) + " bytes, too few for the " +
           image_size + " pixels of the DICOM header (at most " +
           std::to_string(static_cast<int>(per_byte)) + " samples per byte in " +
           dicom_uid_name(info.transfer_syntax_uid) + ")";
  const std::string ratio = compression_ratio_problem(info.decoded_bytes(), bytes);
  if (!ratio.empty()) return "the " + image_size + " pixels of the DICOM header are " + ratio;
  const ExpectedFrame expected{info.rows, info.columns, info.samples_per_pixel, info.bits_allocated,
                               info.bits_stored};
  constexpr Uint32 kHeaderBytes = 16384;  // markers before the frame header fit well within
  std::vector<std::uint8_t> head(kHeaderBytes);
  for (std::size_t f = 0; f < first.size(); ++f) {
    DcmPixelItem* fragment = nullptr;
    if (sequence->getItem(fragment, first[f]).bad() || !fragment)
      return "frame " + std::to_string(f + 1) + " has no fragment";
    const Uint32 length = fragment->getLength();
    const Uint32 n = std::min(length, kHeaderBytes);
    if (n > 0 && fragment->getPartialValue(head.data(), 0, n).bad())
      return "frame " + std::to_string(f + 1) + " cannot be read";
    const std::string d =
        compare_frame_header(info.transfer_syntax_uid, head.data(), n, length, expected);
    if (!d.empty()) return "frame " + std::to_string(f + 1) + ": " + d;
  }
  return "";
}

}  // namespace

const char* to_string(DicomObjectKind kind) {
  switch (kind) {
    case DicomObjectKind::image:
      return "image";
    case DicomObjectKind::localizer:
      return "localizer";
    case DicomObjectKind::unsupported:
      return "unsupported image";
    case DicomObjectKind::non_image:
      return "non-image object";
    case DicomObjectKind::directory:
      return "DICOMDIR";
    case DicomObjectKind::not_dicom:
      return "not DICOM";
    case DicomObjectKind::unreadable:
      return "unreadable DICOM";
  }
  return "?";
}

std::uint64_t DicomFileInfo::decoded_bytes() const {
  return static_cast<std::uint64_t>(rows) * static_cast<std::uint64_t>(columns) *
         static_cast<std::uint64_t>(number_of_frames) *
         static_cast<std::uint64_t>(samples_per_pixel) *
         static_cast<std::uint64_t>((bits_allocated + 7) / 8);
}

std::string dicom_uid_name(const std::string& uid) {
  const char* name = dcmFindNameOfUID(uid.c_str(), nullptr);
  return name ? std::string(name) : uid;
}

bool looks_like_dicom(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::array<unsigned char, 132> head{};
  in.read(reinterpret_cast<char*>(head.data()), head.size());
  const std::streamsize n = in.gcount();
  if (n >= 132 && head[128] == 'D' && head[129] == 'I' && head[130] == 'C' && head[131] == 'M')
    return true;
  if (n < 8) return false;
  // A data set without preamble starts with its lowest group: 0002 (meta) or 0008, little or
  // big endian.
  const unsigned group_le = head[0] | (head[1] << 8);
  const unsigned group_be = (head[0] << 8) | head[1];
  return group_le == 0x0002 || group_le == 0x0008 || group_be == 0x0008;
}

DicomFileInfo read_dicom_file_info(const fs::path& path) {
  setup_imaging_libraries();
  DicomFileInfo info;
  info.path = path;
  if (!fs::is_regular_file(path)) throw Error("'" + path.string() + "' is not a regular file");
  if (!looks_like_dicom(path)) {
    info.kind = DicomObjectKind::not_dicom;
    info.skip_reason = "not DICOM";
    return info;
  }
  // DCMTK parses nested sequences recursively: a hostile depth is refused before it recurses.
  const DicomNesting nesting = dicom_nesting(path, kMaxSequenceDepth);
  if (nesting.depth > kMaxSequenceDepth) {
    info.kind = DicomObjectKind::unreadable;
    info.skip_reason = "sequences nested more than " + std::to_string(kMaxSequenceDepth) +
                       " deep: refused before parsing";
    info.series_instance_uid = nesting.series_instance_uid;
    return info;
  }
  if (!nesting.problem.empty()) {
    info.kind = DicomObjectKind::unreadable;
    info.skip_reason = "damaged or truncated DICOM: " + nesting.problem;
    info.series_instance_uid = nesting.series_instance_uid;
    return info;
  }
  DcmFileFormat file;
  const OFCondition status =
      file.loadFile(path.c_str(), EXS_Unknown, EGL_noChange, kMaxHeaderValueLength, ERM_autoDetect);
  if (status.bad()) {
    info.kind = DicomObjectKind::unreadable;
    info.skip_reason = std::string("damaged or truncated DICOM (") + status.text() + ")";
    // What was parsed before the damage tells which series lost a file.
    info.series_instance_uid = get_string(*file.getDataset(), DCM_SeriesInstanceUID);
    return info;
  }
  DcmDataset& ds = *file.getDataset();
  DcmMetaInfo& meta = *file.getMetaInfo();

  info.sop_class_uid = get_string(ds, DCM_SOPClassUID);
  if (info.sop_class_uid.empty())
    info.sop_class_uid = get_string(meta, DCM_MediaStorageSOPClassUID);
  info.sop_instance_uid = get_string(ds, DCM_SOPInstanceUID);
  info.series_instance_uid = get_string(ds, DCM_SeriesInstanceUID);
  info.frame_of_reference_uid = get_string(ds, DCM_FrameOfReferenceUID);
  info.transfer_syntax_uid = get_string(meta, DCM_TransferSyntaxUID);
  const DcmXfer xfer(ds.getOriginalXfer());
  if (info.transfer_syntax_uid.empty()) info.transfer_syntax_uid = xfer.getXferID();
  info.modality = get_string(ds, DCM_Modality);
  info.series_description = get_string(ds, DCM_SeriesDescription);
  info.series_number = get_string(ds, DCM_SeriesNumber);
  info.manufacturer = get_string(ds, DCM_Manufacturer);
  info.model_name = get_string(ds, DCM_ManufacturerModelName);
  info.image_type = get_string(ds, DCM_ImageType);
  info.has_instance_number = get_long(ds, DCM_InstanceNumber, info.instance_number);
  info.has_gantry_tilt = get_double(ds, DCM_GantryDetectorTilt, info.gantry_tilt_deg);
  info.has_slice_thickness = get_double(ds, DCM_SliceThickness, info.slice_thickness_mm);
  if (DcmItem* mea = sequence_item(sequence_item(&ds, DCM_SharedFunctionalGroupsSequence),
                                   DCM_PixelMeasuresSequence))
    info.has_slice_thickness =
        get_double(*mea, DCM_SliceThickness, info.slice_thickness_mm) || info.has_slice_thickness;
  info.rescale_type = get_string(ds, DCM_RescaleType);
  info.has_pixel_padding_value = get_double(ds, DCM_PixelPaddingValue, info.pixel_padding_value);
  DcmSequenceOfItems* mlut = nullptr;
  info.has_modality_lut =
      ds.findAndGetSequence(DCM_ModalityLUTSequence, mlut).good() && mlut && mlut->card() > 0;

  if (info.sop_class_uid == kMediaStorageDirectoryUid ||
      ds.tagExists(DCM_DirectoryRecordSequence)) {
    info.kind = DicomObjectKind::directory;
    info.skip_reason = "DICOMDIR (directory of a file-set, no pixels)";
    return info;
  }

  DcmElement* pixel_data = nullptr;
  info.has_pixel_data = ds.findAndGetElement(DCM_PixelData, pixel_data).good() && pixel_data;
  if (!info.has_pixel_data) {
    const std::string sop_name =
        info.sop_class_uid.empty() ? "no SOP class" : dicom_uid_name(info.sop_class_uid);
    if (ds.tagExists(DCM_FloatPixelData) || ds.tagExists(DCM_DoubleFloatPixelData)) {
      info.kind = DicomObjectKind::unsupported;
      info.skip_reason = "floating-point pixel data (" + sop_name + "): not a CT image";
    } else {
      info.kind = DicomObjectKind::non_image;
      info.skip_reason = "no pixel data (" + sop_name + ")";
    }
    return info;
  }
  info.pixel_data_encapsulated = xfer.isEncapsulated();
  if (!info.pixel_data_encapsulated) info.pixel_data_bytes = pixel_data->getLength();
  if (!pixel_data_is_complete(*pixel_data, xfer)) {
    info.kind = DicomObjectKind::unreadable;
    info.skip_reason = "truncated: the pixel data end beyond the end of the file";
    return info;
  }

  const std::string binary = binary_value_problem(ds);
  if (!binary.empty()) {
    info.kind = DicomObjectKind::unreadable;
    info.skip_reason = "damaged header: " + binary;
    return info;
  }
  classify_image(ds, info);
  if (info.kind != DicomObjectKind::image && info.kind != DicomObjectKind::localizer) return info;
  if (info.pixel_data_encapsulated) {
    const std::string disagreement = check_compressed_frames(*pixel_data, xfer, info);
    if (!disagreement.empty()) {
      info.kind = DicomObjectKind::unreadable;
      info.skip_reason = "compressed pixel data disagree with the header: " + disagreement;
      return info;
    }
  }
  const DicomObjectKind kind_before_frames = info.kind;
  try {
    read_frames(ds, info);
  } catch (const InvalidValue& e) {
    info.kind = DicomObjectKind::unreadable;
    info.skip_reason = e.what();
    return info;
  }
  if (kind_before_frames == DicomObjectKind::localizer && info.kind == DicomObjectKind::image)
    info.kind = DicomObjectKind::localizer;
  return info;
}

std::vector<std::vector<std::uint8_t>> read_frame_codestreams(const DicomFileInfo& info) {
  const std::string where =
      "'" + info.path.string() + "' (" + dicom_uid_name(info.transfer_syntax_uid) + ")";
  DcmFileFormat file;
  if (file.loadFile(info.path.c_str(), EXS_Unknown, EGL_noChange, kMaxHeaderValueLength,
                    ERM_autoDetect)
          .bad())
    throw Error("cannot re-read " + where + " for its compressed frames");
  DcmDataset& ds = *file.getDataset();
  const DcmXfer xfer(ds.getOriginalXfer());
  DcmElement* element = nullptr;
  auto* pixel = ds.findAndGetElement(DCM_PixelData, element).good()
                    ? dynamic_cast<DcmPixelData*>(element)
                    : nullptr;
  DcmPixelSequence* sequence = nullptr;
  if (!pixel || !xfer.isEncapsulated() ||
      pixel->getEncapsulatedRepresentation(xfer.getXfer(), nullptr, sequence).bad() || !sequence)
    throw Error(where + ": the compressed pixel data have no fragments");
  const unsigned long fragments = sequence->card() > 0 ? sequence->card() - 1 : 0;
  const int frames = info.number_of_frames;
  std::string problem;
  std::vector<unsigned long> first = frame_fragments(*sequence, frames, problem);
  if (!problem.empty()) throw Error(where + ": " + problem);
  auto fragment_at = [&](unsigned long index) {
    DcmPixelItem* fragment = nullptr;
    if (sequence->getItem(fragment, index).bad() || !fragment)
      throw Error(where + ": fragment " + std::to_string(index) + " cannot be read");
    return fragment;
  };
  if (first.size() != static_cast<std::size_t>(frames)) {
    // Several fragments per frame and no offset table: a frame starts where a fragment starts
    // with its codestream's first marker (JPEG SOI, JPEG 2000 SOC or the JP2 signature).
    first.clear();
    for (unsigned long i = 1; i <= fragments; ++i) {
      DcmPixelItem* fragment = fragment_at(i);
      std::uint8_t head[4] = {0, 0, 0, 0};
      const Uint32 n = std::min<Uint32>(fragment->getLength(), 4);
      if (n > 0 && fragment->getPartialValue(head, 0, n).bad())
        throw Error(where + ": fragment " + std::to_string(i) + " cannot be read");
      const bool starts =
          n >= 4 && ((head[0] == 0xFF && (head[1] == 0xD8 || head[1] == 0x4F)) ||
                     (head[0] == 0 && head[1] == 0 && head[2] == 0 && head[3] == 12));
      if (i == 1 || (starts && frames > 1)) first.push_back(i);
    }
    if (frames == 1) first.assign(1, 1);
    if (first.size() != static_cast<std::size_t>(frames))
      throw Error(where + ": " + std::to_string(fragments) + " fragments without an offset " +
                  "table cannot be told apart into " + std::to_string(frames) + " frames");
  }
  std::vector<std::vector<std::uint8_t>> streams(static_cast<std::size_t>(frames));
  for (int f = 0; f < frames; ++f) {
    const unsigned long end =
        f + 1 < frames ? first[static_cast<std::size_t>(f) + 1] : fragments + 1;
    std::vector<std::uint8_t>& out = streams[static_cast<std::size_t>(f)];
    for (unsigned long i = first[static_cast<std::size_t>(f)]; i < end; ++i) {
      DcmPixelItem* fragment = fragment_at(i);
      const Uint32 length = fragment->getLength();
      if (length == 0 || length == DCM_UndefinedLength) continue;
      const std::size_t at = out.size();
      out.resize(at + length);
      if (fragment->getPartialValue(out.data() + at, 0, length).bad())
        throw Error(where + ": fragment " + std::to_string(i) + " cannot be read");
    }
  }
  return streams;
}

DicomDirContents read_dicomdir(const fs::path& dicomdir) {
  setup_imaging_libraries();
  if (dicom_nesting(dicomdir, kMaxSequenceDepth).depth > kMaxSequenceDepth)
    throw Error("DICOMDIR '" + dicomdir.string() + "' nests sequences more than " +
                std::to_string(kMaxSequenceDepth) + " deep: refused before parsing");
  DcmFileFormat file;
  const OFCondition status = file.loadFile(dicomdir.c_str(), EXS_Unknown, EGL_noChange,
                                           kMaxHeaderValueLength, ERM_autoDetect);
  if (status.bad())
    throw Error("cannot read DICOMDIR '" + dicomdir.string() + "': " + status.text());
  DcmSequenceOfItems* records = nullptr;
  if (file.getDataset()->findAndGetSequence(DCM_DirectoryRecordSequence, records).bad() || !records)
    throw Error("DICOMDIR '" + dicomdir.string() +
                "' has no Directory Record Sequence (0004,1220)");
  DicomDirContents contents;
  const fs::path base = fs::absolute(dicomdir).parent_path();
  for (unsigned long r = 0; r < records->card(); ++r) {
    DcmItem* record = records->getItem(r);
    if (!record) continue;
    OFString id;
    if (!has_header_value(*record, DCM_ReferencedFileID) ||
        record->findAndGetOFStringArray(DCM_ReferencedFileID, id).bad() || id.empty())
      continue;
    // A File ID is a relative path of '\\'-separated components (PS3.10 8.5): a component that
    // climbs ("..") or carries a path of its own ('/', ':') would reach files outside the
    // file-set, so the DICOMDIR is refused naming the record and the ID.
    fs::path relative;
    std::string component;
    for (const char c : std::string(id.c_str()) + "\\") {
      if (c != '\\') {
        component += c;
        continue;
      }
      component = trim(component);
      if (component == ".." || component.find_first_of("/:") != std::string::npos)
        throw Error("DICOMDIR '" + dicomdir.string() + "': directory record " +
                    std::to_string(r + 1) + ": ReferencedFileID (0004,1500) '" + id.c_str() +
                    "' leaves the file-set (component '" + component +
                    "'): expected a relative path of '\\'-separated names");
      if (!component.empty() && component != ".") relative /= component;
      component.clear();
    }
    if (relative.empty()) continue;
    fs::path found;
    fs::path dir = base;
    for (int level = 0; level < 4 && found.empty(); ++level) {
      std::error_code ec, ec_dir;
      // Found only where it is a regular file inside `dir` once links are resolved.
      const fs::path real = fs::weakly_canonical(dir / relative, ec);
      const fs::path real_dir = fs::weakly_canonical(dir, ec_dir);
      const auto inside = std::mismatch(real_dir.begin(), real_dir.end(), real.begin(), real.end());
      if (!ec && !ec_dir && inside.first == real_dir.end() && fs::is_regular_file(real, ec))
        found = dir / relative;
      if (!dir.has_parent_path() || dir.parent_path() == dir) break;
      dir = dir.parent_path();
    }
    if (found.empty())
      contents.missing.push_back(id.c_str());
    else if (std::find(contents.files.begin(), contents.files.end(), found) == contents.files.end())
      contents.files.push_back(found);
  }
  return contents;
}

}  // namespace tsf::import
