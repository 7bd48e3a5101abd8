// Finishing touches on the FBX files assimp writes.
//
// Binary FBX: a node record is (end_offset, property count, property bytes, name, properties,
// nested records, and - when it has nested records - a "null record" of zero bytes that ends the
// list; version 7500 and later use 64-bit offsets and a 25-byte null record, older ones 32-bit
// and 13 bytes). assimp 5.2.x writes the null records as empty strings (assimp issue #4686, fixed
// upstream by PR #4824 after 5.2.5), so every nested list lacks its terminator and readers
// (assimp's own, Blender's, the FBX SDK) reject the file. finalise_fbx_binary() parses the node
// tree by its end offsets, writes it again with the terminators (also after nodes without
// properties, as the FBX SDK does), recomputes every offset and the footer's alignment, and sets
// the unit scale. It also deflates every array of 1 KiB or more (array encoding 1, zlib), as the
// FBX SDK does: assimp writes normals and colours per triangle corner as doubles, which makes
// raw files about 4x larger than compressed ones. A document that already has its terminators
// and compressed arrays comes out the same (idempotent).
//
// Units: FBX records the size of one file unit in centimetres as GlobalSettings' UnitScaleFactor
// (assimp writes 1, i.e. centimetres); exporting millimetres sets 0.1, metres 100.
#pragma once

#include <string>
#include <string_view>

namespace tsf::exporter {

/// The repaired binary document with UnitScaleFactor and OriginalUnitScaleFactor set to
/// `unit_scale_cm`. Throws tsf::Error naming the byte offset when `bytes` is not a binary FBX
/// document whose node tree can be walked (truncated, offsets out of range, nesting over 64).
std::string finalise_fbx_binary(std::string_view bytes, double unit_scale_cm);

/// An ASCII FBX document with the unit scale set and `comment` lines (each prefixed with "; ")
/// added after the first line. Throws tsf::Error when the UnitScaleFactor property is missing.
std::string finalise_fbx_ascii(std::string_view text, double unit_scale_cm,
                               const std::string& comment);

/// The UnitScaleFactor of a binary or ASCII FBX document (for tests and reports); throws
/// tsf::Error when absent.
double fbx_unit_scale(std::string_view bytes);

}  // namespace tsf::exporter
