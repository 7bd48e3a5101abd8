// DEFLATE (RFC 1951) and gzip (RFC 1952) decompression, for the gzip-encoded NRRD volumes that
// `tsf segment` writes (nrrd_volume.h): the core reads them without zlib, which the GPU machine's
// build does not link (docs/design.md, "Layers inside the core": tissue/ uses the standard library,
// Eigen, OpenMP and CUDA only).
//
// Every block type (stored, fixed and dynamic Huffman codes) is decoded; the gzip wrapper is
// checked (magic, method, header flags, CRC-32 and length of every member). Malformed input throws
// tsf::Error naming the source and what is wrong; output beyond `max_output` bytes is refused, so
// a corrupt or hostile file never allocates unbounded memory.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace tsf::io {

/// Decompresses a raw DEFLATE stream starting at `data`, appending to `out`. Returns the input
/// bytes consumed (the stream ends at the last block, rounded up to a byte). Throws tsf::Error
/// ("WHAT: …") on malformed or truncated data, or when `out` would exceed `max_output` bytes.
std::size_t inflate(const std::uint8_t* data, std::size_t size, std::vector<std::uint8_t>& out,
                    std::size_t max_output, const std::string& what);

/// Decompresses gzip data (one or more members, each checked by its CRC-32 and length). Throws
/// tsf::Error as inflate() does, and when a member's checksum, length or header is wrong or bytes
/// that are not a gzip member follow the last one.
std::vector<std::uint8_t> gunzip(const std::uint8_t* data, std::size_t size, std::size_t max_output,
                                 const std::string& what);

}  // namespace tsf::io
