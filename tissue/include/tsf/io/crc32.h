// CRC-32 (IEEE 802.3, reflected polynomial 0xEDB88320, the zlib/PNG checksum) over a byte range.
// Used by the mesh sequence file to tell a corrupt record from a valid one.
#pragma once

#include <cstddef>
#include <cstdint>

namespace tsf::io {

/// Continues a CRC-32 over `size` bytes: crc32(b, n) == crc32_update(0, b, n), and
/// crc32_update(crc32(a), b) == crc32(a ++ b). crc32("123456789") == 0xCBF43926.
std::uint32_t crc32_update(std::uint32_t crc, const void* bytes, std::size_t size);

inline std::uint32_t crc32(const void* bytes, std::size_t size) {
  return crc32_update(0, bytes, size);
}

}  // namespace tsf::io
