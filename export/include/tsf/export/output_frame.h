// Where exported vertices go: tissue space -> patient frame -> the file's axes and units.
//
//   tissue space  p, mm: axis-aligned, p = origin + (i·sx, j·sy, k·sz) (voxel_volume.h)
//   patient (LPS) q = origin + D·(p − origin), D = the volume's direction matrix (columns are the
//                 i, j, k axes in LPS): the positions the scanner measured
//   file axes     r = A·q, A a rotation chosen by AxisConvention (export_format.h):
//                   y-up  r = ( q.x,  q.z, −q.y)   x = left, y = superior, z = anterior
//                   lps   r = ( q.x,  q.y,  q.z)
//                   ras   r = (−q.x, −q.y,  q.z)
//   centring      r −= c when asked (c = the bounding-box centre of the first exported state, in
//                 file axes before scaling), so the model sits at the origin of the file
//   units         r ·= 0.001 for metres (glTF always), 1 for millimetres
// Normals map through the inverse transpose of A·D and are renormalised. When det(D) < 0 (a
// left-handed image frame) the map mirrors, so triangle winding is reversed to keep
// counter-clockwise-seen-from-outside.
#pragma once

#include <array>
#include <string>

#include "tsf/common/vec3.h"
#include "tsf/export/export_format.h"
#include "tsf/imt/surface_mesh.h"
#include "tsf/volume/voxel_volume.h"

namespace tsf::exporter {

struct OutputFrame {
  std::array<double, 9> linear{1, 0, 0, 0, 1, 0, 0, 0, 1};  ///< row-major: scale·A·D
  Vec3d translation;  ///< r = linear·p + translation (file units)
  std::array<double, 9> normal_linear{1, 0, 0, 0, 1, 0, 0, 0, 1};  ///< (A·D)^-T, row-major
  bool flips_winding = false;                                      ///< det(D) < 0
  LengthUnit units = LengthUnit::millimetre;
  AxisConvention axes = AxisConvention::lps;
  Vec3d centre_offset;  ///< c, mm in file axes (zero when not centred)

  Vec3d position(const Vec3f& tissue_mm) const;
  Vec3f normal(const Vec3f& tissue_normal) const;  ///< unit (or zero for a zero input)
  /// One line for file headers: "units mm, axes lps (x=left y=posterior z=superior), ..."
  std::string describe() const;
  /// The 4×4 row-major affine tissue (mm) -> file, for metadata.
  std::array<double, 16> matrix() const;
};

/// The frame for `geometry` (throws tsf::Error when its direction matrix is singular or not
/// finite).
OutputFrame make_output_frame(const VolumeGeometry& geometry, AxisConvention axes,
                              LengthUnit units);

/// The same frame, translated so the bounding box of `mesh` (tissue space) is centred on 0.
OutputFrame centred_on(const OutputFrame& frame, const imt::SurfaceMesh& mesh);

/// `mesh` (tissue space) mapped into the file frame: positions, normals, and the winding flipped
/// when the frame mirrors. Labels are kept.
imt::SurfaceMesh to_output_frame(const imt::SurfaceMesh& mesh, const OutputFrame& frame);

}  // namespace tsf::exporter
