#include "dicom_nesting.h"

#include <dcmtk/dcmdata/dctag.h>
#include <zlib.h>

#include <algorithm>
#include <array>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <limits>
#include <memory>
#include <vector>

namespace tsf::import {
namespace {

constexpr std::uint32_t kUndefined = 0xFFFFFFFFu;
constexpr std::uint64_t kNoEnd = std::numeric_limits<std::uint64_t>::max();

/// Bytes of a file from some offset, or of a raw deflate stream there; counts its position.
class Source {
 public:
  virtual ~Source() = default;
  virtual bool read(std::uint8_t* p, std::size_t n) = 0;
  virtual bool skip(std::uint64_t n) = 0;
  std::uint64_t position = 0;
};

/// A file read through a 64 KiB window: skipping a value inside the window costs no system call
/// (a seek per element made the walk as slow as DCMTK's whole header read).
class FileSource final : public Source {
 public:
  explicit FileSource(const std::filesystem::path& path) : in_(path, std::ios::binary) {
    std::error_code ec;
    size_ = std::filesystem::file_size(path, ec);
    if (ec) size_ = 0;
  }
  bool read(std::uint8_t* p, std::size_t n) override { return read_some(p, n) == n; }
  bool skip(std::uint64_t n) override {
    if (n > size_ - std::min(size_, position)) return false;
    return seek(position + n);
  }
  /// Up to `n` bytes; how many were read.
  std::size_t read_some(std::uint8_t* p, std::size_t n) {
    std::size_t got = 0;
    while (got < n) {
      if (position < window_start_ || position >= window_start_ + window_.size()) {
        if (!fill()) break;
      }
      const std::size_t at = static_cast<std::size_t>(position - window_start_);
      const std::size_t k = std::min(n - got, window_.size() - at);
      std::memcpy(p + got, window_.data() + at, k);
      got += k;
      position += k;
    }
    return got;
  }
  bool seek(std::uint64_t to) {
    position = to;
    return to <= size_;
  }

 private:
  bool fill() {
    if (position >= size_) return false;
    in_.clear();
    in_.seekg(static_cast<std::streamoff>(position));
    window_.resize(static_cast<std::size_t>(std::min<std::uint64_t>(kWindow, size_ - position)));
    in_.read(reinterpret_cast<char*>(window_.data()), static_cast<std::streamsize>(window_.size()));
    window_.resize(static_cast<std::size_t>(std::max<std::streamsize>(in_.gcount(), 0)));
    window_start_ = position;
    return !window_.empty();
  }
  static constexpr std::uint64_t kWindow = 1 << 16;
  std::ifstream in_;
  std::uint64_t size_ = 0;
  std::vector<std::uint8_t> window_;
  std::uint64_t window_start_ = 0;
};

/// A Deflated Explicit VR Little Endian data set: raw deflate after the meta header.
class InflateSource final : public Source {
 public:
  explicit InflateSource(FileSource& file) : file_(file) { ok_ = inflateInit2(&z_, -15) == Z_OK; }
  ~InflateSource() override {
    if (ok_) inflateEnd(&z_);
  }
  InflateSource(const InflateSource&) = delete;
  InflateSource& operator=(const InflateSource&) = delete;
  bool read(std::uint8_t* p, std::size_t n) override {
    z_.next_out = p;
    z_.avail_out = static_cast<uInt>(n);
    while (ok_ && z_.avail_out > 0) {
      if (z_.avail_in == 0) {
        const std::size_t got = file_.read_some(input_.data(), input_.size());
        if (got == 0) return false;
        z_.next_in = input_.data();
        z_.avail_in = static_cast<uInt>(got);
      }
      const int r = inflate(&z_, Z_NO_FLUSH);
      if (r == Z_STREAM_END && z_.avail_out > 0) return false;
      if (r != Z_OK && r != Z_STREAM_END && r != Z_BUF_ERROR) return false;
    }
    position += n;
    return ok_;
  }
  bool skip(std::uint64_t n) override {
    std::array<std::uint8_t, 4096> scratch;
    while (n > 0) {
      const std::size_t k = static_cast<std::size_t>(std::min<std::uint64_t>(n, scratch.size()));
      if (!read(scratch.data(), k)) return false;
      n -= k;
    }
    return true;
  }

 private:
  FileSource& file_;
  z_stream z_{};
  std::array<std::uint8_t, 4096> input_{};
  bool ok_ = false;
};

/// One open sequence or item: where it ends and how its elements are encoded.
struct Open {
  bool sequence = false;
  bool pixel = false;     ///< encapsulated pixel data: its items are fragments, not data sets
  bool implicit = false;  ///< elements inside use implicit VR (an undefined-length UN)
  std::uint64_t end = kNoEnd;
};

bool long_length_vr(const char vr[2]) {
  static const char* const kLong[] = {"OB", "OD", "OF", "OL", "OV", "OW", "SQ",
                                      "SV", "UC", "UN", "UR", "UT", "UV"};
  for (const char* v : kLong)
    if (vr[0] == v[0] && vr[1] == v[1]) return true;
  return false;
}

std::string overrun(unsigned group, unsigned element, std::uint64_t length) {
  char text[128];
  std::snprintf(text, sizeof text,
                "element (%04X,%04X) declares %llu bytes, more than the file holds after it", group,
                element, static_cast<unsigned long long>(length));
  return text;
}

}  // namespace

DicomNesting dicom_nesting(const std::filesystem::path& path, int limit) {
  DicomNesting result;
  FileSource file(path);
  std::uint8_t b[8];
  // Preamble and meta header (always explicit VR little endian).
  std::uint64_t start = 0;
  if (file.skip(128) && file.read(b, 4) && std::memcmp(b, "DICM", 4) == 0) start = 132;
  file.seek(start);
  std::string syntax;
  bool meta = false;
  for (;;) {
    const std::uint64_t at = file.position;
    if (!file.read(b, 8)) return result;
    const unsigned group = b[0] | (b[1] << 8), element = b[2] | (b[3] << 8);
    const bool vr_letters = b[4] >= 'A' && b[4] <= 'Z' && b[5] >= 'A' && b[5] <= 'Z';
    if (group == 0x0002 && !vr_letters && meta) {
      char text[64];
      std::snprintf(text, sizeof text, "meta information element (0002,%04X) has no valid VR",
                    element);
      result.problem = text;
    }
    if (group != 0x0002 || !vr_letters) {
      file.seek(at);
      break;
    }
    meta = true;
    std::uint64_t length = b[6] | (b[7] << 8);
    if (long_length_vr(reinterpret_cast<const char*>(b + 4))) {
      if (!file.read(b, 4)) return result;
      length = std::uint64_t{b[0]} | (std::uint64_t{b[1]} << 8) | (std::uint64_t{b[2]} << 16) |
               (std::uint64_t{b[3]} << 24);
    }
    if (element == 0x0010 && length < 256) {
      std::string uid(static_cast<std::size_t>(length), '\0');
      if (!file.read(reinterpret_cast<std::uint8_t*>(uid.data()), uid.size())) return result;
      while (!uid.empty() && (uid.back() == '\0' || uid.back() == ' ')) uid.pop_back();
      syntax = uid;
    } else if (!file.skip(length)) {
      result.problem = overrun(0x0002, element, length);
      return result;
    }
  }
  bool big_endian = syntax == "1.2.840.10008.1.2.2";
  bool implicit = syntax == "1.2.840.10008.1.2";
  if (!meta) {  // no meta header: explicit when a VR follows the first tag
    std::uint8_t first[6];
    const std::uint64_t at = file.position;
    if (!file.read(first, 6)) return result;
    file.seek(at);
    implicit = !(first[4] >= 'A' && first[4] <= 'Z' && first[5] >= 'A' && first[5] <= 'Z');
  }
  std::unique_ptr<InflateSource> inflated;
  Source* in = &file;
  if (syntax == "1.2.840.10008.1.2.1.99") {
    inflated = std::make_unique<InflateSource>(file);
    in = inflated.get();
  }

  auto u16 = [&](const std::uint8_t* p) {
    return big_endian ? static_cast<unsigned>((p[0] << 8) | p[1])
                      : static_cast<unsigned>(p[0] | (p[1] << 8));
  };
  auto u32 = [&](const std::uint8_t* p) {
    return big_endian ? (std::uint32_t{p[0]} << 24) | (std::uint32_t{p[1]} << 16) |
                            (std::uint32_t{p[2]} << 8) | p[3]
                      : std::uint32_t{p[0]} | (std::uint32_t{p[1]} << 8) |
                            (std::uint32_t{p[2]} << 16) | (std::uint32_t{p[3]} << 24);
  };
  std::vector<Open> stack;
  int depth = 0;
  auto pop = [&] {
    if (stack.back().sequence && !stack.back().pixel) --depth;
    stack.pop_back();
  };
  for (;;) {
    while (!stack.empty() && stack.back().end != kNoEnd && in->position >= stack.back().end) pop();
    if (!in->read(b, 4)) return result;
    const unsigned group = u16(b), element = u16(b + 2);
    const bool here_implicit = stack.empty() ? implicit : stack.back().implicit;
    if (group == 0xFFFE) {  // item, item delimitation, sequence delimitation: 4-byte length
      if (!in->read(b, 4)) return result;
      const std::uint32_t length = u32(b);
      if (element == 0xE000) {
        if (stack.empty() || !stack.back().sequence) return result;  // an item outside a sequence
        if (stack.back().pixel) {
          if (length == kUndefined) return result;
          if (!in->skip(length)) {
            if (in == &file) result.problem = overrun(group, element, length);
            return result;
          }
          continue;
        }
        stack.push_back(
            {false, false, here_implicit, length == kUndefined ? kNoEnd : in->position + length});
      } else if (element == 0xE00D) {
        if (stack.empty() || stack.back().sequence) return result;
        pop();
      } else if (element == 0xE0DD) {
        if (!stack.empty() && !stack.back().sequence) pop();
        if (stack.empty()) return result;
        pop();
      }
      continue;
    }
    std::uint64_t length = 0;
    bool sequence = false, unknown_sequence = false;
    if (here_implicit) {
      if (!in->read(b, 4)) return result;
      length = u32(b);
      sequence =
          length == kUndefined ||
          DcmTag(DcmTagKey(static_cast<Uint16>(group), static_cast<Uint16>(element))).getEVR() ==
              EVR_SQ;
    } else {
      if (!in->read(b, 4)) return result;
      const char vr[2] = {static_cast<char>(b[0]), static_cast<char>(b[1])};
      if (!(vr[0] >= 'A' && vr[0] <= 'Z' && vr[1] >= 'A' && vr[1] <= 'Z')) {
        // DCMTK and GDCM read a different length after a VR that is no VR.
        char text[96];
        std::snprintf(text, sizeof text, "element (%04X,%04X) has no valid VR (bytes %02X %02X)",
                      group, element, b[0], b[1]);
        result.problem = text;
        return result;
      }
      if (long_length_vr(vr)) {
        if (!in->read(b, 4)) return result;
        length = u32(b);
      } else {
        length = u16(b + 2);
      }
      unknown_sequence = length == kUndefined && vr[0] == 'U' && vr[1] == 'N';
      sequence = (vr[0] == 'S' && vr[1] == 'Q') || unknown_sequence;
    }
    const std::uint64_t end = length == kUndefined ? kNoEnd : in->position + length;
    if (group == 0x7FE0 && element == 0x0010 && length == kUndefined) {
      stack.push_back({true, true, here_implicit, end});  // encapsulated pixel data: fragments
      continue;
    }
    if (sequence) {
      // An undefined-length UN holds implicit VR little endian data sets.
      stack.push_back({true, false, here_implicit || unknown_sequence, end});
      result.depth = std::max(result.depth, ++depth);
      if (depth > limit) return result;
      continue;
    }
    if (length == kUndefined) return result;  // not a sequence: cannot be followed
    if (stack.empty() && group == 0x0020 && element == 0x000E && length < 128) {
      std::string uid(static_cast<std::size_t>(length), '\0');
      if (!in->read(reinterpret_cast<std::uint8_t*>(uid.data()), uid.size())) return result;
      while (!uid.empty() && (uid.back() == '\0' || uid.back() == ' ')) uid.pop_back();
      result.series_instance_uid = uid;
      continue;
    }
    if (!in->skip(length)) {
      if (in == &file) result.problem = overrun(group, element, length);
      return result;
    }
  }
}

}  // namespace tsf::import
