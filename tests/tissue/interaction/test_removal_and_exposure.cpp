// Tissue-dependent and force-dependent removal, and exposure events of overlay labels: per-label
// ablation and cut rates, an ablation rate that follows the contact force (zero without contact),
// contact forces while ablating, and events when an edit removes tissue near a vessel.
#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <vector>

#include "interaction_test_helpers.h"
#include "tsf/interaction/exposure.h"
#include "tsf/volume/tissue_labels.h"
#include "tsf/volume/volume_edits.h"

namespace tsf::interaction {
namespace {

using test::block_options;
using test::block_volume;

/// A 36 × 16 × 16 mm block (1 mm voxels): mucosa for y < 9.5, cortical bone above.
VoxelVolume two_tissue_block() {
  VoxelVolume v = block_volume({40, 20, 20}, {2, 2, 2}, {38, 18, 18});
  label_box(v, {0, 0, 0}, {40, 9.4, 20}, kLabelMucosa);
  label_box(v, {0, 9.6, 0}, {40, 20, 20}, kLabelCorticalBone);
  return v;
}

double by_label(const std::vector<std::pair<std::uint8_t, double>>& v, std::uint8_t label) {
  for (const auto& [l, mm3] : v)
    if (l == label) return mm3;
  return 0.0;
}

TEST(RemovalRates, MucosaIsAblatedFasterThanBoneByTheRatioOfTheirRates) {
  TissueModelOptions o = block_options(6.0, 0.0);
  o.removal.rates = LabelRates::uniform(1.0f);
  o.removal.rates.rate[kLabelCorticalBone] = 0.25f;
  TissueModel model(two_tissue_block(), std::move(o));
  Tool ball;
  ball.radius_mm = 3.0;
  // Dragged along the interface y = 9.5 inside the block: each tissue gets half the sweep.
  double mucosa = 0, bone = 0;
  for (int s = 0; s <= 8; ++s) {
    const EditReport r =
        model.apply_tool(ball, {{12.0 + 2.0 * s, 9.5, 10.0}, {}}, ToolMode::kAblate);
    mucosa += by_label(r.removed_by_label, kLabelMucosa);
    bone += by_label(r.removed_by_label, kLabelCorticalBone);
  }
  ASSERT_GT(mucosa, 100.0);
  EXPECT_NEAR(bone / mucosa, 0.25, 0.025);
  EXPECT_NEAR(model.totals().removed_by_label_mm3[kLabelMucosa], mucosa, 1e-6 * mucosa);
  EXPECT_NEAR(mucosa + bone, model.totals().removed_mm3, 1e-6 * mucosa);
  // What the ball reached of each tissue: removed / reached is the label's rate.
  const auto& reached = model.totals().reached_by_label_mm3;
  EXPECT_NEAR(mucosa / reached[kLabelMucosa], 1.0, 1e-6);
  EXPECT_NEAR(bone / reached[kLabelCorticalBone], 0.25, 1e-6);
}

TEST(RemovalRates, ABladeCutsMucosaButNotBoneWhoseCutRateIsZero) {
  TissueModelOptions o = block_options(6.0, 0.0);
  o.cut_rates.rate[kLabelCorticalBone] = 0.0f;
  TissueModel model(two_tissue_block(), std::move(o));
  Tool blade;
  blade.shape = collision::ToolShape::kBlade;
  blade.half_extents_mm = {12.0, 12.0, 0.5};
  const Rotation across_x = Rotation::about_axis({0, 1, 0}, M_PI / 2);
  model.apply_tool(blade, {{20, 10, 30}, across_x}, ToolMode::kCut);
  const EditReport r = model.apply_tool(blade, {{20, 10, -10}, across_x}, ToolMode::kCut);
  EXPECT_GT(by_label(r.removed_by_label, kLabelMucosa), 10.0);
  EXPECT_EQ(by_label(r.removed_by_label, kLabelCorticalBone), 0.0);
}

/// A ball lowered onto the block's top (z = 18) by 0.5 mm per frame in ablate mode;
/// `force_before` receives the contact force the tool felt before each move.
std::vector<EditReport> lower_a_wand(TissueModel& model, int frames,
                                     std::vector<double>* force_before = nullptr) {
  Tool ball;
  ball.radius_mm = 2.0;
  std::vector<EditReport> reports;
  for (int f = 0; f < frames; ++f) {
    if (force_before) force_before->push_back(length(model.contact().force_un));
    reports.push_back(model.apply_tool(ball, {{20, 10, 20.5 - 0.5 * f}, {}}, ToolMode::kAblate));
    model.advance(1e-3);
  }
  return reports;
}

TEST(FeatherAblation, NothingIsRemovedWithoutContactAndTheRateFollowsTheForce) {
  TissueModelOptions o = block_options(6.0, 0.0);
  o.feather_force_un = 20e3;  // 20 mN
  TissueModel model(block_volume({40, 20, 20}, {2, 2, 2}, {38, 18, 18}), std::move(o));
  std::vector<double> force;
  const std::vector<EditReport> r = lower_a_wand(model, 12, &force);
  // The first touch: no force yet, so nothing is removed however deep the falloff reaches.
  ASSERT_GE(r.size(), 2u);
  EXPECT_EQ(r[0].rate_scale, 0.0);
  EXPECT_EQ(r[0].removed_mm3, 0.0);
  double force_max = 0, removed = 0;
  for (std::size_t i = 0; i < r.size(); ++i) {
    // Each move's rate follows the contact force the tool felt before it.
    EXPECT_NEAR(r[i].rate_scale, 1.0 - std::exp(-force[i] / 20e3), 1e-9) << "move " << i;
    force_max = std::max(force_max, length(r[i].contact.force_un));
    removed += r[i].removed_mm3;
  }
  EXPECT_GT(force_max, 1e3) << "the ablating tool must press the tissue (µN)";
  EXPECT_GT(removed, 1.0) << "pressing, it must ablate";
  EXPECT_GT(model.latest_contact().nodes_held, 0u);
  model.release_tool();
  EXPECT_EQ(model.latest_contact().nodes_held, 0u);
}

TEST(FeatherAblation, TheSameForceRemovesLessUnderAHeavierFeatherForce) {
  // The same press, then one ablating move: a light feather force (20 mN) takes nearly the
  // full rate, a heavy one (2 N) a fraction of it. Each voxel loses min(density, rate × weight):
  // the removal falls at least in proportion to the rate where the density does not cap it, so
  // its ratio lies between the rates' ratio and 1.
  auto one_move = [](double feather_un, double& scale) {
    TissueModelOptions o = block_options(6.0, 0.0);
    o.feather_force_un = feather_un;
    TissueModel model(block_volume({40, 20, 20}, {2, 2, 2}, {38, 18, 18}), std::move(o));
    Tool ball;
    ball.radius_mm = 2.0;
    model.apply_tool(ball, {{20, 10, 18.5}, {}}, ToolMode::kPress);
    for (int f = 0; f < 3; ++f) model.advance(1e-3);
    const EditReport r = model.apply_tool(ball, {{20, 10, 18.5}, {}}, ToolMode::kAblate);
    scale = r.rate_scale;
    return r.removed_mm3;
  };
  double light_scale = 0, heavy_scale = 0;
  const double light = one_move(20e3, light_scale), heavy = one_move(2000e3, heavy_scale);
  ASSERT_GT(heavy, 0.0);
  EXPECT_GT(light_scale, 0.99);
  EXPECT_LT(heavy_scale, 0.5);
  EXPECT_GE(heavy / light, heavy_scale / light_scale - 1e-6);
  EXPECT_LT(heavy / light, 0.5 * (1.0 + heavy_scale / light_scale))
      << "light " << light << " mm³ at " << light_scale << ", heavy " << heavy << " mm³ at "
      << heavy_scale;
}

TEST(FeatherAblation, WithoutItAblationExertsNoForceAndRemovesAtTheFullRate) {
  TissueModel model(block_volume({40, 20, 20}, {2, 2, 2}, {38, 18, 18}), block_options(6.0, 0.0));
  for (const EditReport& r : lower_a_wand(model, 8)) {
    EXPECT_EQ(r.rate_scale, 1.0);
    EXPECT_EQ(length(r.contact.force_un), 0.0);
  }
  EXPECT_GT(model.totals().removed_mm3, 10.0);
}

TEST(FeatherAblation, PressingTissueAgainstAnchoredBoneMovesNoNodeFar) {
  // Soft tissue over an anchored bone layer (z < 9); a wand lowered through the soft tissue into
  // the bone, pressing as it ablates. Vertices held mostly by anchored corners cannot be pushed
  // out: their free corners must not be flung away (a corner moves at most 4× the push).
  VoxelVolume v = block_volume({40, 20, 20}, {2, 2, 2}, {38, 18, 18});
  label_box(v, {0, 0, 0}, {40, 20, 9}, kLabelCorticalBone);
  TissueModelOptions o = block_options(-1.0, 0.0);
  o.anchor = [](crms::Lattice& l) { crms::fix_nodes_with_labels(l, {kLabelCorticalBone}); };
  o.feather_force_un = 5e3;
  TissueModel model(std::move(v), std::move(o));
  Tool wand;
  wand.shape = collision::ToolShape::kCapsule;
  wand.radius_mm = 1.5;
  wand.half_length_mm = 3.0;
  const Rotation along_x = Rotation::about_axis({0, 1, 0}, M_PI / 2);
  double force_max = 0;
  for (int f = 0; f < 16; ++f) {
    const EditReport r =
        model.apply_tool(wand, {{20.0 + 0.7 * f, 10, 20.0 - 0.8 * f}, along_x}, ToolMode::kAblate);
    force_max = std::max(force_max, length(r.contact.force_un));
    model.advance(1e-3);
  }
  ASSERT_TRUE(test::all_finite(model));
  const auto u = model.solver().displacements();
  double farthest = 0;
  for (std::int64_t n = 0; n < model.solver().lattice().node_count(); ++n)
    if (model.solver().lattice().alive(n))
      farthest = std::max(farthest, double(length(u[static_cast<std::size_t>(n)])));
  EXPECT_LT(farthest, 6.0) << "a node was moved " << farthest << " mm";
  EXPECT_LT(force_max, 10e6) << "µN";
}

/// A block of soft tissue with a vessel (label 64) along y at x = 20, z = 10, radius 1 mm.
VoxelVolume block_with_vessel() {
  VoxelVolume v = block_volume({40, 20, 20}, {2, 2, 2}, {38, 18, 18});
  label_capsule(v, {{20, 2, 10}, {20, 18, 10}, 1.0}, kLabelVessel);
  return v;
}

/// The exposures of ablating `ball` from block_with_vessel(), watching `o`'s labels.
std::vector<ExposureHit> exposures_of(const SphereTool& ball, const ExposureOptions& o) {
  VoxelVolume v = block_with_vessel();
  DensitySnapshot before;
  const VoxelBox all = VoxelBox::of_dims(v.dims());
  before.capture(v, all);
  ablate_sphere(v, ball);
  return find_exposures(v, before, all, 0.5f, o);
}

TEST(Exposure, AnEditReportsItsDistanceToTheNearestWatchedVoxel) {
  // Remove a ball of radius 2 centred 6 mm from the vessel axis along x (x = 14): the voxels
  // taken below the iso-level reach x = 15 (x = 16 lies on the ball's surface and keeps density
  // 0.5), the vessel's voxels start at x = 19: 4 mm.
  const SphereTool ball{{14, 10, 10}, 2.0};
  ExposureOptions o;
  o.distance_mm = 4.5;
  const std::vector<ExposureHit> hits = exposures_of(ball, o);
  ASSERT_EQ(hits.size(), 1u);
  EXPECT_EQ(hits[0].label, kLabelVessel);
  EXPECT_NEAR(hits[0].distance_mm, 4.0, 1e-9);
  EXPECT_NEAR(hits[0].label_mm.x, 19.0, 1e-9);
  // Beyond the distance: nothing; another watched label: nothing.
  o.distance_mm = 3.5;
  EXPECT_TRUE(exposures_of(ball, o).empty());
  o.distance_mm = 4.5;
  o.labels = {kLabelNerve};
  EXPECT_TRUE(exposures_of(ball, o).empty());
}

TEST(Exposure, RemovingTheVesselItselfIsDistanceZero) {
  ExposureOptions o;
  o.distance_mm = 1.0;
  const std::vector<ExposureHit> hits = exposures_of({{20, 10, 13}, 2.5}, o);
  ASSERT_EQ(hits.size(), 1u);
  EXPECT_EQ(hits[0].distance_mm, 0.0);
}

TEST(Exposure, TheModelRaisesAnEventOnEachCloserApproachAndFiresItsTrigger) {
  TissueModelOptions o = block_options(6.0, 0.0);
  o.exposure.distance_mm = 3.0;
  o.solver.materials.resize(2);
  o.solver.materials[1] = o.solver.materials[0];
  o.solver.effects.animation.enabled = true;
  o.configure_effects = [](const crms::Lattice& l, crms::SolverConfig& c) {
    crms::CutTrigger t;
    t.name = "vessel-exposed";
    t.entry = 1;
    t.event = exposure_event_name(kLabelVessel);
    for (std::int64_t n = 0; n < l.node_count(); ++n)
      if (l.alive(n) && l.label(n) == kLabelVessel) t.nodes.push_back(n);
    c.effects.animation.cut_triggers = {t};
  };
  TissueModel model(block_with_vessel(), std::move(o));
  Tool ball;
  ball.radius_mm = 1.5;
  // From x = 8 towards the vessel at x = 20 in 1 mm moves: tissue within 3 mm of the vessel
  // (x ≥ 16 for removed voxels, the ball's front at x + 1.5) is first removed at x = 14.5.
  std::vector<double> first_at;
  std::size_t events = 0;
  for (int s = 0; s <= 8; ++s) {
    const double x = 8.0 + s;
    const EditReport r = model.apply_tool(ball, {{x, 10, 10}, {}}, ToolMode::kAblate);
    for (const ExposureEvent& e : r.exposures) {
      ++events;
      if (e.first) first_at.push_back(x);
      EXPECT_EQ(e.hit.label, kLabelVessel);
      EXPECT_LE(e.hit.distance_mm, 3.0 + 1e-9);
    }
    if (s == 0) {
      EXPECT_TRUE(model.solver().fired_triggers().empty());
    }
  }
  ASSERT_EQ(first_at.size(), 1u);
  EXPECT_GE(first_at[0], 14.0);
  EXPECT_LE(first_at[0], 15.0);
  EXPECT_GE(events, 2u) << "closer approaches raise further events";
  // Distances of successive events decrease strictly.
  const auto& all = model.exposure_events();
  for (std::size_t i = 1; i < all.size(); ++i)
    EXPECT_LT(all[i].hit.distance_mm, all[i - 1].hit.distance_mm);
  EXPECT_EQ(model.solver().fired_triggers(), std::vector<std::string>{"vessel-exposed"});
}

}  // namespace
}  // namespace tsf::interaction
