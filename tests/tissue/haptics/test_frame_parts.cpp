// A live loop's frame holds only what its force model reads (ForceModel::reads(),
// TissueFrameCapture::set_parts): the simulation thread then spends nothing per frame on windows
// the model never looks at, and each model's force is the one it feels from a full frame.
#include <gtest/gtest.h>

#include <memory>

#include "haptics_test_helpers.h"
#include "tsf/haptics/force_models.h"
#include "tsf/haptics/frame_capture.h"
#include "tsf/interaction/tissue_model.h"

namespace tsf::haptics {
namespace {

TEST(FrameParts, ACaptureHoldsOnlyWhatItsModelReadsAndEveryModelFeelsTheSameForce) {
  // A ball of tissue (radius 6 mm, 1 mm voxels) and a 2 mm stylus reaching 1 mm into its top.
  VoxelVolume ball = test::sphere_volume_of(6.0, 20.0, 1.0, 0.5);
  const Vec3d centre = test::volume_centre(ball);
  interaction::TissueModelOptions o;
  o.lattice.node_spacing_voxels = 2;
  o.solver.backend = crms::Backend::kCpu;
  o.solver.gravity = {0, 0, 0};
  interaction::TissueModel model(std::move(ball), o);
  StylusPose pose;
  pose.position = centre + Vec3d{0, 0, 6.0 + 2.0 - 1.0};
  const Vec3d contact{1, 2, 3};

  TissueFrameCapture full_capture({2.0, 3.0});
  HapticFrame full;
  full_capture.capture(model, pose, contact, 4, 0.5, full);
  ASSERT_FALSE(full.displacement.empty());
  ASSERT_FALSE(full.density.empty());
  ASSERT_FALSE(full.corners.empty()) << "the stylus must reach the surface";

  ForceModelOptions fo;
  fo.stylus_radius_mm = 2.0;
  for (ForceModelKind kind :
       {ForceModelKind::kVoxel, ForceModelKind::kLattice, ForceModelKind::kMesh}) {
    const std::unique_ptr<ForceModel> m = make_force_model(kind, fo);
    const FrameParts parts = m->reads();
    TissueFrameCapture capture({2.0, 3.0});
    capture.set_parts(parts);
    HapticFrame frame;
    capture.capture(model, pose, contact, 4, 0.5, frame);
    const char* name = to_string(kind);
    EXPECT_EQ(!frame.displacement.empty(), parts.lattice) << name;
    EXPECT_EQ(!frame.density.empty(), parts.density) << name;
    EXPECT_EQ(!frame.corners.empty(), parts.triangles) << name;
    EXPECT_EQ(frame.contact_force_un, contact) << name;
    EXPECT_EQ(frame.contact_nodes, 4) << name;
    const HapticForce a = m->evaluate(full.view(), pose), b = m->evaluate(frame.view(), pose);
    EXPECT_EQ(a.force_un, b.force_un) << name;
    EXPECT_EQ(a.contacts, b.contacts) << name;
    if (kind != ForceModelKind::kLattice) {
      EXPECT_GT(length(a.force_un), 0.0) << name << ": the stylus reaches into the tissue";
    }
  }
  // The lattice model reads no window at all.
  const FrameParts none = LatticeForceModel(fo).reads();
  EXPECT_FALSE(none.lattice || none.density || none.triangles);
}

}  // namespace
}  // namespace tsf::haptics
