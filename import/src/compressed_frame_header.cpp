#include "compressed_frame_header.h"

#include <algorithm>

namespace tsf::import {
namespace {

const char* const kJpegPrefix = "1.2.840.10008.1.2.4.";

/// The codestream kind of a transfer syntax: JPEG (processes 1–14), JPEG-LS, JPEG 2000, RLE.
enum class Codec { none, jpeg, jpeg_ls, j2k, rle };

Codec codec_of(const std::string& uid) {
  if (uid == "1.2.840.10008.1.2.5") return Codec::rle;
  if (uid.rfind(kJpegPrefix, 0) != 0) return Codec::none;
  const std::string rest = uid.substr(std::string(kJpegPrefix).size());
  if (rest.find('.') != std::string::npos || rest.empty()) return Codec::none;
  const int process = std::stoi(rest);
  if (process >= 50 && process <= 70) return Codec::jpeg;
  if (process == 80 || process == 81) return Codec::jpeg_ls;
  if (process == 90 || process == 91) return Codec::j2k;
  return Codec::none;
}

unsigned be16(const std::uint8_t* p) {
  return (unsigned{p[0]} << 8) | p[1];
}
std::uint32_t be32(const std::uint8_t* p) {
  return (std::uint32_t{p[0]} << 24) | (std::uint32_t{p[1]} << 16) | (std::uint32_t{p[2]} << 8) |
         p[3];
}
std::uint32_t le32(const std::uint8_t* p) {
  return std::uint32_t{p[0]} | (std::uint32_t{p[1]} << 8) | (std::uint32_t{p[2]} << 16) |
         (std::uint32_t{p[3]} << 24);
}

/// What a codestream header declares.
struct Declared {
  std::uint64_t columns = 0, rows = 0;
  unsigned components = 0, precision = 0;
};

std::string size_text(std::uint64_t columns, std::uint64_t rows) {
  return std::to_string(columns) + "×" + std::to_string(rows);
}

/// Compares a JPEG, JPEG-LS or JPEG 2000 header's declarations with the DICOM header's.
std::string compare(const char* marker, const Declared& d, const ExpectedFrame& e) {
  const std::string what = std::string("the ") + marker + " says ";
  // A JPEG frame may leave its height to a later DNL marker (rows = 0).
  if (d.columns != static_cast<std::uint64_t>(e.columns) ||
      (d.rows != static_cast<std::uint64_t>(e.rows) && d.rows != 0))
    return what + size_text(d.columns, d.rows) + " pixels, the DICOM header (Columns×Rows) " +
           size_text(static_cast<std::uint64_t>(e.columns), static_cast<std::uint64_t>(e.rows));
  if (d.components != static_cast<unsigned>(e.samples_per_pixel))
    return what + std::to_string(d.components) + " components, the DICOM header " +
           std::to_string(e.samples_per_pixel) + " SamplesPerPixel";
  if (e.bits_allocated != 8 && e.bits_allocated != 16)
    return "BitsAllocated is " + std::to_string(e.bits_allocated) + " but " + marker +
           " frames decode to 8 or 16 bits per sample";
  // Precision may differ from BitsStored either way (a 14-bit J2K of 16-bit stored samples
  // decodes exactly), but the samples must fit the allocated bits.
  if (d.precision < 1 || d.precision > static_cast<unsigned>(e.bits_allocated))
    return what + std::to_string(d.precision) + " bits per sample, the DICOM header " +
           std::to_string(e.bits_stored) + " BitsStored of " + std::to_string(e.bits_allocated) +
           " BitsAllocated";
  return "";
}

/// The frame header of a JPEG (SOF0–SOF15) or JPEG-LS (SOF55) stream; "" in `error` on success.
bool read_jpeg_sof(const std::uint8_t* p, std::size_t n, bool jpeg_ls, Declared& d,
                   std::string& error) {
  if (n < 4 || p[0] != 0xFF || p[1] != 0xD8) {
    error = "the frame does not start with a JPEG SOI marker";
    return false;
  }
  std::size_t at = 2;
  while (at + 4 <= n) {
    if (p[at] != 0xFF) {
      error =
          "the JPEG stream has no marker where one is expected (byte " + std::to_string(at) + ")";
      return false;
    }
    const unsigned m = p[at + 1];
    if (m == 0xFF) {  // fill byte
      ++at;
      continue;
    }
    if (m == 0x01 || (m >= 0xD0 && m <= 0xD7)) {  // markers without a length
      at += 2;
      continue;
    }
    const unsigned length = be16(p + at + 2);
    const bool sof =
        jpeg_ls ? m == 0xF7 : (m >= 0xC0 && m <= 0xCF && m != 0xC4 && m != 0xC8 && m != 0xCC);
    if (sof) {
      if (length < 8 || at + 2 + 8 > n) break;
      d.precision = p[at + 4];
      d.rows = be16(p + at + 5);
      d.columns = be16(p + at + 7);
      d.components = p[at + 9];
      return true;
    }
    if (m == 0xDA || m == 0xD9) {  // start of scan or end of image before any frame header
      error = jpeg_ls ? "the JPEG-LS stream has no SOF55 frame header before its scan"
                      : "the JPEG stream has no SOF frame header before its scan";
      return false;
    }
    if (length < 2) break;
    at += 2 + length;
  }
  error = std::string("the first ") + std::to_string(n) + " bytes of the frame hold no " +
          (jpeg_ls ? "JPEG-LS SOF55" : "JPEG SOF") + " frame header";
  return false;
}

/// The SIZ segment of a JPEG 2000 codestream (after SOC; a JP2 wrapper is searched through).
bool read_j2k_siz(const std::uint8_t* p, std::size_t n, Declared& d, std::string& error) {
  std::size_t at = 0;
  while (at + 4 <= n &&
         !(p[at] == 0xFF && p[at + 1] == 0x4F && p[at + 2] == 0xFF && p[at + 3] == 0x51))
    ++at;
  // After SOC and the SIZ marker: Lsiz, Rsiz, Xsiz, Ysiz, XOsiz, YOsiz, 4 tile fields, Csiz (at
  // byte 36), then Ssiz, XRsiz, YRsiz per component.
  if (at + 4 + 38 > n) {
    error = "the first " + std::to_string(n) + " bytes of the frame hold no JPEG 2000 SIZ segment";
    return false;
  }
  const std::uint8_t* s = p + at + 4;
  const std::uint32_t x = be32(s + 4), y = be32(s + 8), x0 = be32(s + 12), y0 = be32(s + 16);
  if (x0 > x || y0 > y) {
    error = "the JPEG 2000 SIZ has an image offset beyond its size";
    return false;
  }
  d.columns = x - x0;
  d.rows = y - y0;
  d.components = be16(s + 36);
  if (d.components < 1 || at + 4 + 38 + 3 * std::size_t{d.components} > n) {
    error = "the JPEG 2000 SIZ segment is cut short";
    return false;
  }
  for (unsigned c = 0; c < d.components; ++c) {
    const unsigned precision = (s[38 + 3 * c] & 0x7F) + 1u;
    const unsigned xr = s[39 + 3 * c], yr = s[40 + 3 * c];
    if (c == 0) d.precision = precision;
    if (precision != d.precision || xr != 1 || yr != 1) {
      error = "the JPEG 2000 SIZ declares components of different precision or subsampling";
      return false;
    }
  }
  return true;
}

/// The RLE header: 64 bytes, the segment count then 15 offsets (PS3.5 G.5).
std::string compare_rle(const std::uint8_t* p, std::size_t n, std::uint64_t fragment_length,
                        const ExpectedFrame& e) {
  if (n < 64) return "the RLE frame is shorter than its 64-byte header";
  const std::uint32_t segments = le32(p);
  const std::uint64_t bytes_per_sample = static_cast<std::uint64_t>(e.bits_allocated + 7) / 8;
  const std::uint64_t expected = bytes_per_sample * static_cast<std::uint64_t>(e.samples_per_pixel);
  if (segments != expected)
    return "the RLE header has " + std::to_string(segments) + " segments, the DICOM header " +
           std::to_string(e.samples_per_pixel) + " SamplesPerPixel × " +
           std::to_string(e.bits_allocated) + " BitsAllocated needs " + std::to_string(expected);
  std::uint64_t previous = 64;
  const std::uint64_t plane = static_cast<std::uint64_t>(e.rows) * e.columns;
  for (std::uint32_t s = 0; s < segments; ++s) {
    const std::uint64_t offset = le32(p + 4 + 4 * s);
    const std::uint64_t end = s + 1 < segments ? le32(p + 8 + 4 * s) : fragment_length;
    if ((s == 0 && offset != 64) || offset < previous || end < offset || end > fragment_length)
      return "the RLE segment table is inconsistent (segment " + std::to_string(s + 1) +
             " at byte " + std::to_string(offset) + " of " + std::to_string(fragment_length) + ")";
    // PackBits turns 2 bytes into at most 128: a segment cannot hold more than 64× its length.
    if (plane > 64 * (end - offset))
      return "RLE segment " + std::to_string(s + 1) + " holds " + std::to_string(end - offset) +
             " bytes, too few for the " + size_text(e.columns, e.rows) +
             " pixels of the DICOM header (Columns×Rows; at most 64 pixels per byte)";
    previous = offset;
  }
  return "";
}

}  // namespace

double max_samples_per_compressed_byte(const std::string& transfer_syntax_uid) {
  if (codec_of(transfer_syntax_uid) != Codec::jpeg) return 0;
  const int process = std::stoi(transfer_syntax_uid.substr(std::string(kJpegPrefix).size()));
  if (process == 57 || process == 70) return 8;
  if (process == 50 || process == 51) return 256;
  return 0;
}

bool one_fragment_per_frame(const std::string& transfer_syntax_uid) {
  return codec_of(transfer_syntax_uid) == Codec::rle;
}

bool has_checked_frame_header(const std::string& transfer_syntax_uid) {
  return codec_of(transfer_syntax_uid) != Codec::none;
}

std::string compare_frame_header(const std::string& transfer_syntax_uid, const std::uint8_t* data,
                                 std::size_t n, std::uint64_t fragment_length,
                                 const ExpectedFrame& expected) {
  Declared d;
  std::string error;
  switch (codec_of(transfer_syntax_uid)) {
    case Codec::none:
      return "";
    case Codec::rle:
      return compare_rle(data, n, fragment_length, expected);
    case Codec::jpeg:
      if (!read_jpeg_sof(data, n, false, d, error)) return error;
      return compare("JPEG SOF", d, expected);
    case Codec::jpeg_ls:
      if (!read_jpeg_sof(data, n, true, d, error)) return error;
      return compare("JPEG-LS SOF55", d, expected);
    case Codec::j2k:
      if (!read_j2k_siz(data, n, d, error)) return error;
      return compare("JPEG 2000 SIZ", d, expected);
  }
  return "";
}

}  // namespace tsf::import
