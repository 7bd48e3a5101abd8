#include "compressed_frame_header.h"

#include <algorithm>
#include <cstring>

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

std::string hex16(unsigned v) {
  static const char* digits = "0123456789ABCDEF";
  std::string s = "0x";
  for (int shift = 12; shift >= 0; shift -= 4) s += digits[(v >> shift) & 0xF];
  return s;
}

/// Whether `n` bytes end a codestream whose end marker closes at `end`: at most one padding
/// byte may follow (PS3.5 A.4).
std::string trailing_problem(std::size_t end, std::size_t n, const char* marker) {
  if (n - end > 1)
    return std::to_string(n - end) + " bytes follow the " + marker +
           " marker (at most one padding byte may)";
  return "";
}

/// JPEG 2000 (ISO/IEC 15444-1 Annex A): the structure every decoder relies on.
std::string check_j2k(const std::uint8_t* p, std::size_t n) {
  // A JP2 file (signature box) carries the codestream in its 'jp2c' box.
  if (n >= 12 && be32(p) == 12 && be32(p + 4) == 0x6A502020u) {
    std::size_t at = 0;
    bool found = false;
    while (at + 8 <= n) {
      std::uint64_t length = be32(p + at);
      const std::uint32_t type = be32(p + at + 4);
      std::size_t header = 8;
      if (length == 1) {
        if (at + 16 > n) break;
        length = (std::uint64_t{be32(p + at + 8)} << 32) | be32(p + at + 12);
        header = 16;
      } else if (length == 0) {
        length = n - at;
      }
      if (length < header || length > n - at) return "a JP2 box overruns the frame";
      if (type == 0x6A703263u) {  // 'jp2c'
        p += at + header;
        n = static_cast<std::size_t>(length) - header;
        found = true;
        break;
      }
      at += static_cast<std::size_t>(length);
    }
    if (!found) return "the JP2 file has no codestream box";
  }
  if (n < 2 || be16(p) != 0xFF4F) return "the frame does not start with a JPEG 2000 SOC marker";
  if (n < 4 + 38 || be16(p + 2) != 0xFF51) return "SIZ does not follow SOC";
  const std::uint8_t* s = p + 4;  // Lsiz, Rsiz, Xsiz, Ysiz, XOsiz, YOsiz, XTsiz, YTsiz, ...
  const unsigned lsiz = be16(s);
  if (lsiz < 41 || 2 + 2 + std::size_t{lsiz} > n) return "the SIZ segment overruns the frame";
  const std::uint64_t x = be32(s + 4), y = be32(s + 8), x0 = be32(s + 12), y0 = be32(s + 16);
  const std::uint64_t tx = be32(s + 20), ty = be32(s + 24), tx0 = be32(s + 28), ty0 = be32(s + 32);
  if (tx == 0 || ty == 0 || tx0 > x0 || ty0 > y0 || tx0 + tx <= x0 || ty0 + ty <= y0 || x0 >= x ||
      y0 >= y)
    return "the SIZ tile grid does not cover the image";
  const std::uint64_t tiles_x = (x - tx0 + tx - 1) / tx, tiles_y = (y - ty0 + ty - 1) / ty;
  if (tiles_x * tiles_y > 65535) return "the SIZ declares more than 65535 tiles";
  const std::size_t tiles = static_cast<std::size_t>(tiles_x * tiles_y);

  std::size_t at = 4 + lsiz;
  bool cod = false, qcd = false, sop_allowed = false, eph_allowed = false, packed = false;
  std::vector<std::uint64_t> tlm;  // tile-part lengths from TLM, in order
  while (true) {
    if (at + 2 > n) return "the codestream ends inside its main header";
    const unsigned m = be16(p + at);
    if (m == 0xFF90) break;
    if (m == 0xFFD9) return "the codestream has no tile-part";
    if ((m >> 8) != 0xFF || m < 0xFF30)
      return "no marker where the main header continues (byte " + std::to_string(at) + ")";
    if (m <= 0xFF3F) {
      at += 2;
      continue;
    }
    if (at + 4 > n) return "the codestream ends inside its main header";
    const unsigned length = be16(p + at + 2);
    if (length < 2 || at + 2 + length > n)
      return "marker segment " + hex16(m) + " at byte " + std::to_string(at) +
             " overruns the frame";
    const std::uint8_t* v = p + at + 4;  // the segment's parameters
    if (m == 0xFF52 && length >= 3) {    // COD: Scod
      cod = true;
      sop_allowed = (v[0] & 0x02) != 0;
      eph_allowed = (v[0] & 0x04) != 0;
    }
    if (m == 0xFF5C) qcd = true;
    if (m == 0xFF60) packed = true;    // PPM: packet headers in the main header
    if (m == 0xFF55 && length >= 4) {  // TLM: Ztlm, Stlm, then (Ttlm, Ptlm) pairs
      const unsigned st = (v[1] >> 4) & 3, sp = (v[1] >> 6) & 1;
      const std::size_t entry = st + (sp ? 4 : 2);
      if (st == 3 || (length - 4) % entry != 0) return "a TLM segment has a broken layout";
      for (std::size_t e = 4; e < length; e += entry) {
        const std::uint8_t* q = p + at + 2 + e + st;
        tlm.push_back(sp ? be32(q) : be16(q));
      }
    }
    at += 2 + length;
  }
  if (!cod || !qcd) return "the main header lacks its COD or QCD segment";

  // The codestream ends with EOC (one padding byte may follow).
  std::size_t eoc = n >= 2 ? n - 2 : 0;
  if (n >= 3 && be16(p + n - 2) != 0xFFD9 && be16(p + n - 3) == 0xFFD9) eoc = n - 3;
  if (n < 2 || be16(p + eoc) != 0xFFD9)
    return "the codestream does not end with an EOC marker (truncated or damaged)";

  std::vector<unsigned> parts(tiles, 0), declared_parts(tiles, 0), next_sop(tiles, 0);
  std::size_t tile_parts = 0;
  while (at != eoc) {
    if (at + 12 > eoc || be16(p + at) != 0xFF90)
      return "no SOT marker where tile-part " + std::to_string(tile_parts + 1) +
             " should start (byte " + std::to_string(at) + ")";
    const unsigned lsot = be16(p + at + 2), tile = be16(p + at + 4);
    const std::uint64_t psot = be32(p + at + 6);
    const unsigned part = p[at + 10], of = p[at + 11];
    const std::string name =
        "tile-part " + std::to_string(part) + " of tile " + std::to_string(tile);
    if (lsot != 10) return name + ": Lsot is " + std::to_string(lsot) + ", not 10";
    if (tile >= tiles)
      return name + ": the image has only " + std::to_string(tiles) + " tiles (SIZ)";
    if (part != parts[tile])
      return name + " comes where part " + std::to_string(parts[tile]) + " is due";
    if (of != 0) {
      if (declared_parts[tile] != 0 && declared_parts[tile] != of)
        return name + ": the tile's part count changes from " +
               std::to_string(declared_parts[tile]) + " to " + std::to_string(of);
      declared_parts[tile] = of;
      if (part >= of)
        return name + " is beyond the " + std::to_string(of) + " parts the tile declares";
    }
    const std::size_t end = psot == 0 ? eoc : at + static_cast<std::size_t>(psot);
    if (psot != 0 && (psot < 14 || psot > eoc - at))
      return name + " declares " + std::to_string(psot) + " bytes (Psot), the codestream holds " +
             std::to_string(eoc - at) + " before EOC";
    if (!tlm.empty() && (tile_parts >= tlm.size() || (psot != 0 && tlm[tile_parts] != psot)))
      return name + ": its length disagrees with the TLM segment";
    // The tile-part header, up to SOD.
    std::size_t q = at + 12;
    bool sod = false, tile_packed = packed;
    std::uint64_t plt_sum = 0;
    bool plt = false;
    while (q + 2 <= end) {
      const unsigned m = be16(p + q);
      if (m == 0xFF93) {
        sod = true;
        q += 2;
        break;
      }
      if ((m >> 8) != 0xFF || m < 0xFF30)
        return name + ": no marker in its header (byte " + std::to_string(q) + ")";
      if (m <= 0xFF3F) {
        q += 2;
        continue;
      }
      if (q + 4 > end) break;
      const unsigned length = be16(p + q + 2);
      if (length < 2 || q + 2 + length > end)
        return name + ": marker segment " + hex16(m) + " overruns the tile-part";
      if (m == 0xFF61) tile_packed = true;  // PPT
      if (m == 0xFF58) {                    // PLT: Zplt, then packet lengths, 7 bits a byte
        plt = true;
        std::uint64_t value = 0;
        for (std::size_t b = q + 5; b < q + 2 + length; ++b) {
          value = (value << 7) | (p[b] & 0x7F);
          if ((p[b] & 0x80) == 0) {
            plt_sum += value;
            value = 0;
          }
        }
      }
      q += 2 + length;
    }
    if (!sod) return name + " has no SOD marker";
    if (plt && !tile_packed && plt_sum != end - q)
      return name + ": its packets hold " + std::to_string(end - q) +
             " bytes, its PLT lengths add up to " + std::to_string(plt_sum);
    // Coded data: a marker code 0xFF90..0xFFFF cannot occur there (A.1), except SOP and EPH.
    for (std::size_t b = q; b + 1 < end; ++b) {
      if (p[b] != 0xFF || p[b + 1] < 0x90) continue;
      const unsigned m = 0xFF00u | p[b + 1];
      if (m == 0xFF91 && sop_allowed && b + 6 <= end && be16(p + b + 2) == 4) {
        const unsigned number = be16(p + b + 4);
        if (number != (next_sop[tile] & 0xFFFFu))
          return name + ": packet " + std::to_string(number) + " (SOP) where packet " +
                 std::to_string(next_sop[tile] & 0xFFFFu) + " is due";
        ++next_sop[tile];
        b += 5;
        continue;
      }
      if (m == 0xFF92 && eph_allowed) {
        ++b;
        continue;
      }
      return name + ": marker code " + hex16(m) + " inside the coded data (byte " +
             std::to_string(b) + "), where the format forbids one";
    }
    ++parts[tile];
    ++tile_parts;
    at = end;
  }
  if (!tlm.empty() && tlm.size() != tile_parts)
    return "the TLM segment lists " + std::to_string(tlm.size()) + " tile-parts, the codestream " +
           "holds " + std::to_string(tile_parts);
  for (std::size_t t = 0; t < tiles; ++t) {
    if (parts[t] == 0)
      return "tile " + std::to_string(t) + " of " + std::to_string(tiles) +
             " has no data (a decoder would leave it blank)";
    if (declared_parts[t] != 0 && parts[t] != declared_parts[t])
      return "tile " + std::to_string(t) + " has " + std::to_string(parts[t]) + " of its " +
             std::to_string(declared_parts[t]) + " tile-parts";
  }
  return trailing_problem(eoc + 2, n, "EOC");
}

/// JPEG (ITU T.81) or JPEG-LS (ITU T.87): markers, restart sequence and EOI.
std::string check_jpeg(const std::uint8_t* p, std::size_t n, bool jpeg_ls) {
  const char* kind = jpeg_ls ? "JPEG-LS" : "JPEG";
  if (n < 2 || be16(p) != 0xFFD8)
    return std::string("the frame does not start with a ") + kind + " SOI marker";
  std::size_t at = 2;
  bool frame = false, lossless = false, progressive = false;
  std::uint64_t columns = 0, rows = 0, restart_interval = 0;
  int scans = 0;
  std::uint64_t restarts_in_first_scan = 0;
  while (true) {
    while (at + 1 < n && p[at] == 0xFF && p[at + 1] == 0xFF) ++at;  // fill bytes
    if (at + 2 > n)
      return std::string("the ") + kind + " stream ends without an EOI marker (truncated)";
    if (p[at] != 0xFF)
      return std::string("no ") + kind + " marker where one is expected (byte " +
             std::to_string(at) + ")";
    const unsigned m = p[at + 1];
    if (m == 0xD9) break;
    if (m == 0x01 || (m >= 0xD0 && m <= 0xD7)) {
      at += 2;
      continue;
    }
    if (at + 4 > n) return std::string("the ") + kind + " stream ends inside a marker segment";
    const unsigned length = be16(p + at + 2);
    if (length < 2 || at + 2 + length > n)
      return "marker segment " + hex16(0xFF00u | m) + " at byte " + std::to_string(at) +
             " overruns the frame";
    const bool sof =
        jpeg_ls ? m == 0xF7 : (m >= 0xC0 && m <= 0xCF && m != 0xC4 && m != 0xC8 && m != 0xCC);
    if (sof) {
      if (frame) return std::string("the ") + kind + " stream has two frame headers";
      if (length < 8) return "the frame header is cut short";
      frame = true;
      rows = be16(p + at + 5);
      columns = be16(p + at + 7);
      lossless = !jpeg_ls && (m == 0xC3 || m == 0xC7 || m == 0xCB || m == 0xCF);
      progressive = !jpeg_ls && (m == 0xC2 || m == 0xC6 || m == 0xCA || m == 0xCE);
    }
    if (m == 0xDD && length >= 4) restart_interval = be16(p + at + 4);
    if (m == 0xDC && length >= 4) rows = be16(p + at + 4);  // DNL
    at += 2 + length;
    if (m != 0xDA) continue;
    if (!frame) return std::string("a scan comes before the ") + kind + " frame header";
    // Entropy-coded data up to the next marker. JPEG stuffs 0x00 after a data 0xFF; JPEG-LS
    // stuffs a zero bit, so a data 0xFF is followed by a byte below 0x80.
    unsigned next_restart = 0;
    std::uint64_t restarts = 0;
    while (true) {
      const void* ff = at < n ? std::memchr(p + at, 0xFF, n - at) : nullptr;
      if (!ff) return std::string("the ") + kind + " scan runs to the end of the frame (no EOI)";
      std::size_t b = static_cast<std::size_t>(static_cast<const std::uint8_t*>(ff) - p);
      if (b + 1 >= n)
        return std::string("the ") + kind + " stream ends without an EOI marker (truncated)";
      const unsigned c = p[b + 1];
      if ((!jpeg_ls && c == 0x00) || (jpeg_ls && c < 0x80)) {
        at = b + 2;
        continue;
      }
      if (c == 0xFF) {
        at = b + 1;
        continue;
      }
      if (c >= 0xD0 && c <= 0xD7) {
        if (c - 0xD0 != next_restart)
          return "restart marker RST" + std::to_string(c - 0xD0) + " where RST" +
                 std::to_string(next_restart) + " is due (scan " + std::to_string(scans + 1) +
                 ", after " + std::to_string(restarts) + " restarts): a part of the " + kind +
                 " data is missing or damaged";
        next_restart = (next_restart + 1) % 8;
        ++restarts;
        at = b + 2;
        continue;
      }
      at = b;
      break;
    }
    if (scans == 0) restarts_in_first_scan = restarts;
    ++scans;
  }
  if (!frame || scans == 0) return std::string("the ") + kind + " stream holds no frame or scan";
  // One sequential or lossless scan of the one component: the restart interval fixes the count
  // (an MCU is an 8×8 block, or one sample in lossless mode).
  if (!jpeg_ls && !progressive && scans == 1 && restart_interval > 0 && rows > 0) {
    const std::uint64_t units = lossless ? columns * rows : ((columns + 7) / 8) * ((rows + 7) / 8);
    const std::uint64_t expected = (units + restart_interval - 1) / restart_interval - 1;
    if (restarts_in_first_scan != expected)
      return "the scan holds " + std::to_string(restarts_in_first_scan) +
             " restart markers, its restart interval implies " + std::to_string(expected) +
             ": a part of the JPEG data is missing or damaged";
  }
  return trailing_problem(at + 2, n, "EOI");
}

/// RLE (PS3.5 G.3): every segment's PackBits runs decode to exactly one byte per pixel.
std::string check_rle(const std::uint8_t* p, std::size_t n, const ExpectedFrame& e) {
  if (n < 64) return "the RLE frame is shorter than its 64-byte header";
  const std::uint32_t segments = le32(p);
  if (segments < 1 || segments > 15)
    return "the RLE header declares " + std::to_string(segments) + " segments";
  const std::uint64_t plane = static_cast<std::uint64_t>(e.rows) * e.columns;
  for (std::uint32_t s = 0; s < segments; ++s) {
    const std::uint64_t begin = le32(p + 4 + 4 * s);
    const std::uint64_t end = s + 1 < segments ? le32(p + 8 + 4 * s) : n;
    if (begin < 64 || end < begin || end > n)
      return "the RLE segment table is inconsistent (segment " + std::to_string(s + 1) + ")";
    std::uint64_t out = 0;
    std::uint64_t i = begin;
    while (i < end && out < plane) {
      const int c = static_cast<std::int8_t>(p[i++]);
      if (c >= 0) {
        const std::uint64_t literal = static_cast<std::uint64_t>(c) + 1;
        if (i + literal > end)
          return "RLE segment " + std::to_string(s + 1) +
                 " ends inside a literal run (truncated or damaged)";
        out += literal;
        i += literal;
      } else if (c != -128) {
        if (i >= end)
          return "RLE segment " + std::to_string(s + 1) + " ends inside a replicate run";
        out += static_cast<std::uint64_t>(1 - c);
        ++i;
      }
    }
    if (out != plane)
      return "RLE segment " + std::to_string(s + 1) + " decodes to " + std::to_string(out) +
             " bytes, the image has " + std::to_string(plane) +
             " pixels (Rows×Columns): damaged data";
    if (end - i > 1)
      return "RLE segment " + std::to_string(s + 1) + " holds " + std::to_string(end - i) +
             " bytes beyond its image (at most one padding byte may follow)";
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

std::string compression_ratio_problem(std::uint64_t decoded_bytes, std::uint64_t compressed_bytes) {
  if (decoded_bytes <= kRatioFreeDecodedBytes ||
      static_cast<double>(decoded_bytes) <=
          kMaxCompressionRatio * static_cast<double>(compressed_bytes))
    return "";
  const double ratio =
      static_cast<double>(decoded_bytes) / std::max(1.0, static_cast<double>(compressed_bytes));
  return std::to_string(decoded_bytes) + " bytes of pixels from " +
         std::to_string(compressed_bytes) + " compressed bytes (" +
         std::to_string(static_cast<long long>(ratio)) + ":1; a CT compresses at most about " +
         "15:1, tsf accepts up to " + std::to_string(static_cast<int>(kMaxCompressionRatio)) +
         ":1 above " + std::to_string(kRatioFreeDecodedBytes >> 20) +
         " MiB): refused before allocating";
}

std::string check_frame_codestream(const std::string& transfer_syntax_uid, const std::uint8_t* data,
                                   std::size_t n, const ExpectedFrame& expected) {
  switch (codec_of(transfer_syntax_uid)) {
    case Codec::none:
      return "";
    case Codec::rle:
      return check_rle(data, n, expected);
    case Codec::jpeg:
      return check_jpeg(data, n, false);
    case Codec::jpeg_ls:
      return check_jpeg(data, n, true);
    case Codec::j2k:
      return check_j2k(data, n);
  }
  return "";
}

}  // namespace tsf::import
