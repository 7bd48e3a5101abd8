// Test helpers: a gzip member written by hand (stored blocks: the format's simplest case,
// independent of any encoder) and NRRD files made of a header and such data.
#pragma once

#include <algorithm>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "tsf/io/crc32.h"

namespace tsf::test {

inline std::vector<std::uint8_t> gzip_stored(const std::vector<std::uint8_t>& data) {
  std::vector<std::uint8_t> g = {0x1f, 0x8b, 8, 0, 0, 0, 0, 0, 0, 3};
  std::size_t pos = 0;
  do {
    const std::size_t n = std::min<std::size_t>(65535, data.size() - pos);
    const bool last = pos + n == data.size();
    g.push_back(last ? 1 : 0);
    g.push_back(static_cast<std::uint8_t>(n & 0xff));
    g.push_back(static_cast<std::uint8_t>(n >> 8));
    g.push_back(static_cast<std::uint8_t>(~n & 0xff));
    g.push_back(static_cast<std::uint8_t>((~n >> 8) & 0xff));
    g.insert(g.end(), data.begin() + static_cast<std::ptrdiff_t>(pos),
             data.begin() + static_cast<std::ptrdiff_t>(pos + n));
    pos += n;
  } while (pos < data.size());
  const std::uint32_t crc = io::crc32(data.data(), data.size());
  const auto len = static_cast<std::uint32_t>(data.size());
  for (int k = 0; k < 4; ++k) g.push_back(static_cast<std::uint8_t>(crc >> (8 * k)));
  for (int k = 0; k < 4; ++k) g.push_back(static_cast<std::uint8_t>(len >> (8 * k)));
  return g;
}

/// Writes "NRRD0004\n" + header lines + "\n" + data (gzip-wrapped when `gzip`).
inline void write_nrrd(const std::filesystem::path& path, const std::string& header,
                       const std::vector<std::uint8_t>& data, bool gzip) {
  std::ofstream out(path, std::ios::binary);
  out << "NRRD0004\n" << header << "encoding: " << (gzip ? "gzip" : "raw") << "\n\n";
  const std::vector<std::uint8_t> body = gzip ? gzip_stored(data) : data;
  out.write(reinterpret_cast<const char*>(body.data()), static_cast<std::streamsize>(body.size()));
}

template <typename T>
std::vector<std::uint8_t> as_bytes(const std::vector<T>& v) {
  std::vector<std::uint8_t> b(v.size() * sizeof(T));
  std::copy_n(reinterpret_cast<const std::uint8_t*>(v.data()), b.size(), b.begin());
  return b;
}

}  // namespace tsf::test
