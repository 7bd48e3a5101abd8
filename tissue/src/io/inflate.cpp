#include "tsf/io/inflate.h"

#include <algorithm>
#include <array>
#include <cstring>

#include "tsf/common/error.h"
#include "tsf/io/crc32.h"

namespace tsf::io {
namespace {

constexpr int kMaxBits = 15;   // longest Huffman code (RFC 1951, 3.2.2)
constexpr int kFastBits = 10;  // codes up to this long decode with one table lookup
constexpr int kLiteralCodes = 288;
constexpr int kDistanceCodes = 30;

/// Bits of the input, least significant first (RFC 1951, 3.1.1), through a 64-bit buffer.
class BitReader {
 public:
  BitReader(const std::uint8_t* data, std::size_t size, const std::string& what)
      : data_(data), size_(size), what_(what) {}

  /// Makes at least n ≤ 57 bits available; throws when the input ends first.
  void need(int n) {
    while (count_ < n) {
      if (pos_ >= size_) throw Error(what_ + ": the compressed data ends in the middle of a block");
      buffer_ |= static_cast<std::uint64_t>(data_[pos_++]) << count_;
      count_ += 8;
    }
  }
  /// Up to 57 bits available without reading past the input (fewer at its end).
  void fill() {
    while (count_ <= 56 && pos_ < size_) {
      buffer_ |= static_cast<std::uint64_t>(data_[pos_++]) << count_;
      count_ += 8;
    }
  }
  std::uint32_t peek() const { return static_cast<std::uint32_t>(buffer_); }
  int available() const { return count_; }
  void drop(int n) {
    buffer_ >>= n;
    count_ -= n;
  }
  std::uint32_t bits(int n) {
    if (n == 0) return 0;
    need(n);
    const auto v = static_cast<std::uint32_t>(buffer_ & ((std::uint64_t{1} << n) - 1));
    drop(n);
    return v;
  }
  /// Drops the bits up to the next byte boundary.
  void align() { drop(count_ & 7); }
  /// Bytes of input consumed so far (whole bytes still in the buffer returned).
  std::size_t consumed() const { return pos_ - static_cast<std::size_t>(count_ / 8); }
  /// Copies n whole bytes (after align()) to `dst`.
  void copy_bytes(std::uint8_t* dst, std::size_t n) {
    while (n > 0 && count_ >= 8) {
      *dst++ = static_cast<std::uint8_t>(buffer_);
      drop(8);
      --n;
    }
    if (n > size_ - pos_) throw Error(what_ + ": a stored block runs past the end of the data");
    std::memcpy(dst, data_ + pos_, n);
    pos_ += n;
  }
  const std::string& what() const { return what_; }

 private:
  const std::uint8_t* data_;
  std::size_t size_;
  std::size_t pos_ = 0;
  std::uint64_t buffer_ = 0;
  int count_ = 0;
  const std::string& what_;
};

/// A canonical Huffman code (RFC 1951, 3.2.2): symbols sorted by code length, a table for the
/// codes of up to kFastBits bits, and the canonical walk for longer ones.
class Huffman {
 public:
  /// Builds the code of `n` code lengths. An over-subscribed set of lengths is an error; an
  /// incomplete one is allowed (a single distance code is legal) and fails only if a missing
  /// code is read.
  void build(const std::uint8_t* lengths, int n, const std::string& what, const char* name) {
    count_.fill(0);
    for (int s = 0; s < n; ++s) ++count_[lengths[s]];
    count_[0] = 0;
    int left = 1;
    for (int len = 1; len <= kMaxBits; ++len) {
      left = 2 * left - count_[len];
      if (left < 0) throw Error(what + ": over-subscribed " + name + " code lengths");
    }
    std::array<std::uint16_t, kMaxBits + 2> offset{};
    for (int len = 1; len <= kMaxBits; ++len) offset[len + 1] = offset[len] + count_[len];
    for (int s = 0; s < n; ++s)
      if (lengths[s] != 0) symbol_[offset[lengths[s]]++] = static_cast<std::uint16_t>(s);
    // The fast table, indexed by the next kFastBits input bits (codes are sent most significant
    // bit first, so a code's index is its bit-reversed value, repeated over the unused bits).
    fast_.fill(0);
    std::uint32_t code = 0;
    int index = 0;
    for (int len = 1; len <= kFastBits; ++len) {
      for (int c = 0; c < count_[len]; ++c, ++code, ++index) {
        std::uint32_t reversed = 0;
        for (int b = 0; b < len; ++b) reversed |= ((code >> b) & 1u) << (len - 1 - b);
        const auto entry = static_cast<std::uint16_t>((symbol_[index] << 4) | len);
        for (std::uint32_t fill = reversed; fill < (1u << kFastBits); fill += 1u << len)
          fast_[fill] = entry;
      }
      code <<= 1;
    }
  }

  int decode(BitReader& in) const {
    in.fill();
    const std::uint16_t e = fast_[in.peek() & ((1u << kFastBits) - 1)];
    if (e != 0 && (e & 15) <= in.available()) {
      in.drop(e & 15);
      return e >> 4;
    }
    // The canonical walk, one bit at a time (codes longer than kFastBits, or the input's end).
    int code = 0, first = 0, index = 0;
    for (int len = 1; len <= kMaxBits; ++len) {
      code |= static_cast<int>(in.bits(1));
      const int count = count_[len];
      if (code - first < count) return symbol_[index + (code - first)];
      index += count;
      first = (first + count) << 1;
      code <<= 1;
    }
    throw Error(in.what() + ": a Huffman code that the block's code table does not hold");
  }

 private:
  std::array<std::uint16_t, kMaxBits + 1> count_{};
  std::array<std::uint16_t, kLiteralCodes> symbol_{};
  std::array<std::uint16_t, 1u << kFastBits> fast_{};
};

constexpr std::array<std::uint16_t, 29> kLengthBase = {3,  4,  5,  6,   7,   8,   9,   10,  11, 13,
                                                       15, 17, 19, 23,  27,  31,  35,  43,  51, 59,
                                                       67, 83, 99, 115, 131, 163, 195, 227, 258};
constexpr std::array<std::uint8_t, 29> kLengthExtra = {0, 0, 0, 0, 0, 0, 0, 0, 1, 1, 1, 1, 2, 2, 2,
                                                       2, 3, 3, 3, 3, 4, 4, 4, 4, 5, 5, 5, 5, 0};
constexpr std::array<std::uint16_t, 30> kDistanceBase = {
    1,   2,   3,   4,   5,   7,    9,    13,   17,   25,   33,   49,   65,    97,    129,
    193, 257, 385, 513, 769, 1025, 1537, 2049, 3073, 4097, 6145, 8193, 12289, 16385, 24577};
constexpr std::array<std::uint8_t, 30> kDistanceExtra = {0, 0, 0,  0,  1,  1,  2,  2,  3,  3,
                                                         4, 4, 5,  5,  6,  6,  7,  7,  8,  8,
                                                         9, 9, 10, 10, 11, 11, 12, 12, 13, 13};

void grow_or_refuse(std::vector<std::uint8_t>& out, std::size_t extra, std::size_t max_output,
                    const std::string& what) {
  if (extra > max_output - std::min(max_output, out.size()) || out.size() > max_output)
    throw Error(what + ": decompresses to more than the expected " + std::to_string(max_output) +
                " bytes");
}

/// The literal/length and distance symbols of one Huffman block.
void inflate_codes(BitReader& in, const Huffman& literals, const Huffman& distances,
                   std::vector<std::uint8_t>& out, std::size_t max_output) {
  for (;;) {
    const int symbol = literals.decode(in);
    if (symbol < 256) {
      if (out.size() >= max_output) grow_or_refuse(out, 1, max_output, in.what());
      out.push_back(static_cast<std::uint8_t>(symbol));
      continue;
    }
    if (symbol == 256) return;
    const int l = symbol - 257;
    if (l >= 29) throw Error(in.what() + ": invalid length code " + std::to_string(symbol));
    const std::size_t length = kLengthBase[l] + in.bits(kLengthExtra[l]);
    const int d = distances.decode(in);
    if (d >= kDistanceCodes)
      throw Error(in.what() + ": invalid distance code " + std::to_string(d));
    const std::size_t distance = kDistanceBase[d] + in.bits(kDistanceExtra[d]);
    if (distance > out.size())
      throw Error(in.what() + ": a match reaches " + std::to_string(distance) +
                  " bytes back, before the start of the data");
    grow_or_refuse(out, length, max_output, in.what());
    const std::size_t from = out.size() - distance;
    if (distance >= length) {
      const std::size_t at = out.size();
      out.resize(at + length);
      std::memcpy(out.data() + at, out.data() + from, length);
    } else {  // overlapping copy: byte by byte repeats the pattern
      for (std::size_t k = 0; k < length; ++k) out.push_back(out[from + k]);
    }
  }
}

void fixed_codes(Huffman& literals, Huffman& distances, const std::string& what) {
  std::array<std::uint8_t, kLiteralCodes> l{};
  for (int s = 0; s < kLiteralCodes; ++s) l[s] = s < 144 ? 8 : s < 256 ? 9 : s < 280 ? 7 : 8;
  literals.build(l.data(), kLiteralCodes, what, "literal/length");
  std::array<std::uint8_t, 32> d{};
  d.fill(5);
  distances.build(d.data(), 32, what, "distance");
}

void dynamic_codes(BitReader& in, Huffman& literals, Huffman& distances) {
  const int nlen = static_cast<int>(in.bits(5)) + 257;
  const int ndist = static_cast<int>(in.bits(5)) + 1;
  const int ncode = static_cast<int>(in.bits(4)) + 4;
  if (nlen > 286 || ndist > 30)
    throw Error(in.what() + ": a dynamic block declares " + std::to_string(nlen) +
                " literal/length and " + std::to_string(ndist) +
                " distance codes (at most 286 and 30)");
  static constexpr std::array<std::uint8_t, 19> kOrder = {16, 17, 18, 0, 8,  7, 9,  6, 10, 5,
                                                          11, 4,  12, 3, 13, 2, 14, 1, 15};
  std::array<std::uint8_t, 19> code_lengths{};
  for (int c = 0; c < ncode; ++c) code_lengths[kOrder[c]] = static_cast<std::uint8_t>(in.bits(3));
  Huffman lengths_code;
  lengths_code.build(code_lengths.data(), 19, in.what(), "code-length");
  std::array<std::uint8_t, 286 + 30> lengths{};
  int index = 0;
  while (index < nlen + ndist) {
    const int symbol = lengths_code.decode(in);
    if (symbol < 16) {
      lengths[index++] = static_cast<std::uint8_t>(symbol);
      continue;
    }
    std::uint8_t value = 0;
    int repeat = 0;
    if (symbol == 16) {
      if (index == 0) throw Error(in.what() + ": a length repeat with no previous length");
      value = lengths[index - 1];
      repeat = 3 + static_cast<int>(in.bits(2));
    } else if (symbol == 17) {
      repeat = 3 + static_cast<int>(in.bits(3));
    } else {
      repeat = 11 + static_cast<int>(in.bits(7));
    }
    if (index + repeat > nlen + ndist)
      throw Error(in.what() + ": code length repeats run past the declared codes");
    for (int r = 0; r < repeat; ++r) lengths[index++] = value;
  }
  if (lengths[256] == 0) throw Error(in.what() + ": a dynamic block without an end-of-block code");
  literals.build(lengths.data(), nlen, in.what(), "literal/length");
  distances.build(lengths.data() + nlen, ndist, in.what(), "distance");
}

std::uint32_t le32(const std::uint8_t* p) {
  return static_cast<std::uint32_t>(p[0]) | (static_cast<std::uint32_t>(p[1]) << 8) |
         (static_cast<std::uint32_t>(p[2]) << 16) | (static_cast<std::uint32_t>(p[3]) << 24);
}

}  // namespace

std::size_t inflate(const std::uint8_t* data, std::size_t size, std::vector<std::uint8_t>& out,
                    std::size_t max_output, const std::string& what) {
  BitReader in(data, size, what);
  Huffman literals, distances;
  for (;;) {
    const bool last = in.bits(1) != 0;
    const std::uint32_t type = in.bits(2);
    if (type == 0) {
      in.align();
      const std::uint32_t len = in.bits(16);
      const std::uint32_t nlen = in.bits(16);
      if ((len ^ 0xffffu) != nlen)
        throw Error(what + ": a stored block's length and its complement disagree");
      grow_or_refuse(out, len, max_output, what);
      const std::size_t at = out.size();
      out.resize(at + len);
      in.copy_bytes(out.data() + at, len);
    } else if (type == 1) {
      fixed_codes(literals, distances, what);
      inflate_codes(in, literals, distances, out, max_output);
    } else if (type == 2) {
      dynamic_codes(in, literals, distances);
      inflate_codes(in, literals, distances, out, max_output);
    } else {
      throw Error(what + ": invalid DEFLATE block type 3");
    }
    if (last) break;
  }
  return in.consumed();
}

std::vector<std::uint8_t> gunzip(const std::uint8_t* data, std::size_t size, std::size_t max_output,
                                 const std::string& what) {
  std::vector<std::uint8_t> out;
  out.reserve(std::min<std::size_t>(max_output, std::size_t{1} << 30));
  std::size_t pos = 0;
  int member = 0;
  while (pos < size) {
    const std::string where = what + " (gzip member " + std::to_string(++member) + ")";
    if (size - pos < 18) throw Error(where + ": too short for a gzip member");
    const std::uint8_t* h = data + pos;
    if (h[0] != 0x1f || h[1] != 0x8b) throw Error(where + ": not gzip data (bad magic bytes)");
    if (h[2] != 8)
      throw Error(where + ": compression method " + std::to_string(h[2]) +
                  ", expected 8 (deflate)");
    const std::uint8_t flags = h[3];
    if (flags & 0xe0) throw Error(where + ": reserved header flags are set");
    std::size_t p = pos + 10;
    auto need = [&](std::size_t n) {
      if (n > size - p) throw Error(where + ": the header runs past the end of the data");
    };
    if (flags & 4) {  // FEXTRA
      need(2);
      const std::size_t xlen = data[p] | (static_cast<std::size_t>(data[p + 1]) << 8);
      p += 2;
      need(xlen);
      p += xlen;
    }
    for (int field = 0; field < 2; ++field)  // FNAME, FCOMMENT: zero-terminated
      if (flags & (field == 0 ? 8 : 16)) {
        while (true) {
          need(1);
          if (data[p++] == 0) break;
        }
      }
    if (flags & 2) {  // FHCRC
      need(2);
      p += 2;
    }
    const std::size_t start = out.size();
    p += inflate(data + p, size - p, out, max_output, where);
    if (size - p < 8) throw Error(where + ": the CRC-32 and length trailer is missing");
    const std::uint32_t crc = le32(data + p), length = le32(data + p + 4);
    if (crc32(out.data() + start, out.size() - start) != crc)
      throw Error(where + ": CRC-32 mismatch (the data is corrupt)");
    if (static_cast<std::uint32_t>(out.size() - start) != length)
      throw Error(where + ": length mismatch (the data is corrupt)");
    pos = p + 8;
  }
  if (member == 0) throw Error(what + ": no gzip data");
  return out;
}

}  // namespace tsf::io
