// The geometry a CT can have, checked where header values are read (DICOM attributes, volume
// file headers) before anything is built from them: a value outside is an error naming it, never
// a volume placed or scaled by nonsense (import.md, "Limits and safety").
#pragma once

namespace tsf::import {

/// Positions and origins lie within 1 km of the frame's origin, mm.
constexpr double kMaxCoordinateMm = 1e6;
/// Voxel and pixel spacings are positive and at most 1 m, mm.
constexpr double kMaxSpacingMm = 1000;

}  // namespace tsf::import
