// Finishing the binary PLY files assimp writes.
//
// assimp 5.2's binary PLY writer declares vertex colours as "uchar red/green/blue/alpha" but
// writes each channel as a 4-byte float (assimp issue #3827, fixed upstream by PR #5608 in
// 2024), so every reader (assimp's own included) misreads the vertex rows. repair_ply_binary()
// detects that layout from the data size and rewrites the colour channels as the bytes the
// header promises (round(255·c), clamped). A file whose size matches its header is returned as
// it is, so the repair is idempotent and harmless on a fixed assimp.
#pragma once

#include <string>
#include <string_view>

namespace tsf::exporter {

/// The repaired document, with `comment` (one line) added to the header after the format line.
/// Throws tsf::Error when the document is not a binary little-endian PLY of triangles whose
/// size matches either layout.
std::string finalise_ply_binary(std::string_view bytes, const std::string& comment);

}  // namespace tsf::exporter
