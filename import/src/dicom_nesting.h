// How deep a DICOM file nests its sequences, found by an iterative walk of its elements before
// DCMTK (or GDCM) parses it: both parse nested sequences recursively, so 10,000 undefined-length
// sequences inside each other overflow the stack (import.md, "Limits and safety").
#pragma once

#include <filesystem>
#include <string>

namespace tsf::import {

/// Sequences nested deeper than this are refused (enhanced CT nests 3; structured reports rarely
/// more than 20).
constexpr int kMaxSequenceDepth = 64;

struct DicomNesting {
  int depth = 0;  ///< deepest sequence nesting seen (stops counting past the limit)
  std::string series_instance_uid;  ///< (0020,000E) at the top level, when seen before that
  /// Damage the walk saw that DCMTK reads past but GDCM does not (found by fuzzing): a
  /// meta-information element (group 0002, always explicit VR) whose VR is not two capital
  /// letters (GDCM asserts), any explicit-VR element whose VR is not (DCMTK and GDCM then read
  /// different lengths: GDCM allocated 3 GB for a 3 kB file), an element declaring more bytes
  /// than the file holds after it. "" if none.
  std::string problem;
};

/// Walks the elements of `path` (any transfer syntax, deflated data sets inflated on the fly)
/// without recursion and with one stack entry per open sequence or item, stopping as soon as the
/// depth exceeds `limit`. A file it cannot follow (damaged, cut short) returns what it saw: the
/// DICOM parser reports the damage.
DicomNesting dicom_nesting(const std::filesystem::path& path, int limit);

}  // namespace tsf::import
