// The viewer's simulation side shows what edits lead to: an exposure event becomes the HUD's
// warning line, and a tear re-uploads the surface. No X server needed.
#include <gtest/gtest.h>

#include <memory>
#include <string>
#include <vector>

#include "tsf/crms/lattice_builders.h"
#include "tsf/viewer/simulation_session.h"
#include "tsf/volume/analytic_volumes.h"
#include "tsf/volume/tissue_labels.h"
#include "tsf/volume/volume_edits.h"

namespace tsf::viewer {
namespace {

TEST(SimulationSession, AnExposureEventBecomesTheWarningLine) {
  // A block with a vessel along y at x = 20, z = 6; exposure events within 2 mm of it.
  VolumeGeometry g;
  g.dims = {44, 20, 16};
  g.origin = {-1.5, -1.5, -1.5};
  const Vec3d half{20, 8, 6}, centre{20, 8, 6};
  VoxelVolume volume = make_sdf_volume(
      g, [&](const Vec3d& p) { return box_distance_local(half, p - centre); }, 0.5);
  label_capsule(volume, {{20, -2, 6}, {20, 18, 6}, 1.0}, kLabelVessel);
  interaction::TissueModelOptions o;
  o.lattice.node_spacing_voxels = 2;
  o.solver.backend = crms::Backend::kCpu;
  o.solver.materials.at(0).youngs_modulus_pa = 50000;
  o.solver.materials.at(0).viscosity_pa_s = 5;
  o.anchor = [](crms::Lattice& l) { crms::fix_nodes_in_box(l, {-5, -5, -5}, {2, 25, 25}); };
  o.exposure.distance_mm = 2.0;
  std::vector<NamedTool> tools(1);
  tools[0].name = "wand";
  tools[0].tool.radius_mm = 1.5;
  SimulationSession session(
      std::make_unique<interaction::TissueModel>(std::move(volume), std::move(o)),
      std::move(tools));
  session.publish_initial();
  ToolCommand c;
  c.mode = interaction::ToolMode::kAblate;
  for (double x = 8; x <= 14; x += 1) {
    c.pose.position = {x, 8, 6};
    session.step(1e-3, c);
    EXPECT_TRUE(session.stats().warning.empty()) << "still far from the vessel at x = " << x;
  }
  for (double x = 15; x <= 19 && session.stats().warning.empty(); x += 1) {
    c.pose.position = {x, 8, 6};
    session.step(1e-3, c);
  }
  ASSERT_FALSE(session.stats().warning.empty());
  EXPECT_EQ(session.stats().warning.rfind("vessel exposed: wand removed tissue", 0), 0u)
      << session.stats().warning;
  EXPECT_TRUE(session.stats().error.empty()) << session.stats().error;
}

}  // namespace
}  // namespace tsf::viewer
