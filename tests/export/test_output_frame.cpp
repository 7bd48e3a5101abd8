// Tissue space -> patient frame -> file axes and units (output_frame.h), checked against
// VolumeGeometry::index_to_physical, which the import module uses for the CT itself.
#include <gtest/gtest.h>

#include "export_test_helpers.h"
#include "tsf/common/error.h"
#include "tsf/export/output_frame.h"

namespace tsf::exporter {
namespace {
using namespace test;

Vec3d expected_axes(const Vec3d& lps, AxisConvention axes) {
  switch (axes) {
    case AxisConvention::y_up:
      return {lps.x, lps.z, -lps.y};
    case AxisConvention::lps:
      return lps;
    case AxisConvention::ras:
      return {-lps.x, -lps.y, lps.z};
  }
  return lps;
}

TEST(OutputFrame, PositionsAreThePatientFrameInTheFileAxes) {
  const VolumeGeometry g = oblique_geometry();
  for (AxisConvention axes : {AxisConvention::y_up, AxisConvention::lps, AxisConvention::ras})
    for (LengthUnit units : {LengthUnit::millimetre, LengthUnit::metre}) {
      const OutputFrame f = make_output_frame(g, axes, units);
      const double scale = units == LengthUnit::metre ? 1e-3 : 1.0;
      for (const Vec3d ijk : {Vec3d{0, 0, 0}, Vec3d{3.5, 17.25, 9}, Vec3d{19, 0, 19}}) {
        const Vec3f tissue = to_float(g.index_to_tissue(ijk));
        const Vec3d want = expected_axes(g.index_to_physical(ijk), axes) * scale;
        const Vec3d got = f.position(tissue);
        EXPECT_LT(length(got - want), 1e-5 * scale * 100)
            << axes_name(axes) << " " << unit_name(units);
      }
    }
}

TEST(OutputFrame, YUpPutsSuperiorUpAndAnteriorTowardsTheViewer) {
  VolumeGeometry g = cube_geometry({4, 4, 4});
  const OutputFrame f = make_output_frame(g, AxisConvention::y_up, LengthUnit::millimetre);
  const Vec3d origin = f.position({0, 0, 0});
  EXPECT_NEAR((f.position({0, 0, 1}) - origin).y, 1.0, 1e-12) << "+S (LPS z) is +Y";
  EXPECT_NEAR((f.position({0, -1, 0}) - origin).z, 1.0, 1e-12) << "anterior (LPS −y) is +Z";
  EXPECT_NEAR((f.position({1, 0, 0}) - origin).x, 1.0, 1e-12) << "patient left is +X";
  // A proper rotation: right-handed stays right-handed, winding is kept.
  EXPECT_FALSE(f.flips_winding);
}

TEST(OutputFrame, NormalsFollowTheRotationAndStayUnit) {
  const VolumeGeometry g = oblique_geometry();
  const OutputFrame f = make_output_frame(g, AxisConvention::y_up, LengthUnit::metre);
  const Vec3f n = normalized_or_zero(Vec3f{0.3f, -0.5f, 0.8f});
  const Vec3f got = f.normal(n);
  EXPECT_NEAR(length(got), 1.0f, 1e-6f);
  // A rotation maps the tangent plane's normal like a direction: compare with the mapped
  // difference of two positions along n.
  const Vec3d along = f.position(n * 10.0f) - f.position({0, 0, 0});
  EXPECT_LT(length(to_double(got) - along / length(along)), 1e-6);
  EXPECT_EQ(f.normal({0, 0, 0}), (Vec3f{0, 0, 0}));
}

TEST(OutputFrame, MirroredImageFrameReversesWinding) {
  VolumeGeometry g = cube_geometry({8, 8, 8});
  g.direction = {1, 0, 0, 0, 1, 0, 0, 0, -1};  // slices stored head to foot
  const OutputFrame f = make_output_frame(g, AxisConvention::lps, LengthUnit::millimetre);
  EXPECT_TRUE(f.flips_winding);
  imt::SurfaceMesh tri;
  tri.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  tri.normals = {{0, 0, 1}, {0, 0, 1}, {0, 0, 1}};
  tri.labels = {1, 1, 1};
  tri.triangles = {{0, 1, 2}};
  const imt::SurfaceMesh out = to_output_frame(tri, f);
  const Vec3f face = cross(out.positions[out.triangles[0][1]] - out.positions[out.triangles[0][0]],
                           out.positions[out.triangles[0][2]] - out.positions[out.triangles[0][0]]);
  EXPECT_GT(dot(face, out.normals[0]), 0.0f) << "face normal and vertex normal must agree";
  EXPECT_NEAR(out.normals[0].z, -1.0f, 1e-6f);
}

TEST(OutputFrame, CentringMovesTheBoundingBoxCentreToTheOrigin) {
  const VolumeGeometry g = oblique_geometry();
  const imt::SurfaceMesh mesh = labelled_sphere(g);
  const OutputFrame f =
      centred_on(make_output_frame(g, AxisConvention::y_up, LengthUnit::metre), mesh);
  Vec3d lo{1e9, 1e9, 1e9}, hi{-1e9, -1e9, -1e9};
  for (const Vec3f& p : mesh.positions) {
    const Vec3d r = f.position(p);
    lo = {std::min(lo.x, r.x), std::min(lo.y, r.y), std::min(lo.z, r.z)};
    hi = {std::max(hi.x, r.x), std::max(hi.y, r.y), std::max(hi.z, r.z)};
  }
  EXPECT_LT(length((lo + hi) * 0.5), 1e-9);
  // The offset is recorded in mm and is where the sphere was in the patient frame (y-up axes).
  const Vec3d centre = expected_axes(g.index_to_physical({9.5, 9.5, 9.5}), AxisConvention::y_up);
  EXPECT_LT(length(f.centre_offset - centre), 0.2);
}

TEST(OutputFrame, SingularDirectionIsAnError) {
  VolumeGeometry g = cube_geometry({4, 4, 4});
  g.direction = {1, 0, 0, 1, 0, 0, 0, 0, 1};
  EXPECT_THROW(make_output_frame(g, AxisConvention::lps, LengthUnit::millimetre), Error);
}

}  // namespace
}  // namespace tsf::exporter
