// Heterogeneity palettes with per-node blend weights, animation (rest keyframes, material tracks,
// cut triggers) and node masking (docs/effects.md). Every test runs on the CPU and, where a device
// exists, on CUDA; CrmsEffectsRobustness also runs under ASan + UBSan in CI.
#include <gtest/gtest.h>

#include <cmath>
#include <numeric>

#include "physics_assertions.h"
#include "tsf/common/error.h"
#include "tsf/crms/lattice_builders.h"
#include "tsf/volume/voxel_volume.h"

namespace tsf::crms {
namespace {

using test::assert_energy_bounded;
using test::assert_finite;
using test::available_backends;
using test::box;
using test::deform;
using test::nodes_where;
using test::run_recording_energy;

constexpr double kSoft = 10e3, kStiff = 40e3, kFlaccid = 2e3;  // Pa

/// Palette: 0 soft, 1 stiff, 2 flaccid (all damped alike).
SolverConfig palette_config(Backend backend, double damping_time = 2e-3) {
  SolverConfig c;
  c.backend = backend;
  c.materials = {test::soft_material(kSoft, damping_time),
                 test::soft_material(kStiff, damping_time),
                 test::soft_material(kFlaccid, damping_time)};
  return c;
}

MaterialBlend mix(int a, int b, double fraction_b) {
  return make_material_blend({a, b, a, a}, {1.0 - fraction_b, fraction_b, 0, 0});
}

double mean_displacement(const Solver& s, const std::vector<std::int64_t>& nodes, int axis) {
  const auto u = s.displacements();
  double sum = 0;
  for (std::int64_t n : nodes) sum += static_cast<double>(u[n][axis]);
  return sum / static_cast<double>(nodes.size());
}

/// Static displacement along `axis` of a 5 mm block's loaded face (opposite face clamped), every
/// node of material `blend`.
double block_displacement(Backend backend, MaterialBlend blend, int axis,
                          const SolverConfig* config = nullptr) {
  Lattice l = box({5, 5, 5}, 1);
  for (std::int64_t n = 0; n < l.node_count(); ++n) l.set_material(n, blend);
  Vec3d normal{0, 0, 0};
  normal[axis] = 1;
  fix_nodes_behind_plane(l, {0.6, 0.6, 0.6}, normal);
  const auto face = nodes_where(l, [&](Vec3d p) { return p[axis] > 4.4; });
  Solver s(std::move(l), config ? *config : palette_config(backend));
  std::vector<Vec3f> forces(face.size(), Vec3f{0, 0, 0});
  for (auto& f : forces) f[axis] = 20.0f;
  s.set_external_forces(face, forces);
  const double dt = 0.9 * s.stable_dt();
  s.step(static_cast<int>(0.1 / dt), dt);
  EXPECT_TRUE(assert_finite(s));
  return mean_displacement(s, face, axis);
}

TEST(CrmsPalette, BlendWeightsSumTo255AndMergeRepeatedEntries) {
  const MaterialBlend b = make_material_blend({3, 5, 3, 7}, {0.2, 0.3, 0.1, 0.4});
  unsigned sum = 0;
  double w3 = 0, w5 = 0, w7 = 0;
  for (int c = 0; c < 4; ++c) {
    sum += b.weight_of(c);
    if (b.weight_of(c) == 0) continue;
    (b.entry(c) == 3 ? w3 : b.entry(c) == 5 ? w5 : w7) += b.weight_of(c);
  }
  EXPECT_EQ(sum, 255u);
  EXPECT_NEAR(w3, 0.3 * 255, 1.0);  // 0.2 + 0.1 merged
  EXPECT_NEAR(w5, 0.3 * 255, 1.0);
  EXPECT_NEAR(w7, 0.4 * 255, 1.0);
  EXPECT_EQ(b.entry(0), 7);  // heaviest first
  EXPECT_TRUE(make_material_blend({4, 1, 2, 3}, {0, 0, 0, 0}).pure());
  EXPECT_EQ(make_material_blend({4, 1, 2, 3}, {0, 0, 0, 0}).entry(0), 4);
}

TEST(CrmsPalette, StiffnessFollowsTheBlendWeights) {
  for (Backend backend : available_backends()) {
    const double soft = block_displacement(backend, MaterialBlend::single(0), 0);
    ASSERT_GT(soft, 0) << to_string(backend);
    for (double f : {0.25, 0.5, 1.0}) {
      const double mixed = block_displacement(backend, mix(0, 1, f), 0);
      // Rule of mixtures: E = (1 − f)·E0 + f·E1; displacement ∝ 1/E.
      const double expected = kSoft / ((1 - f) * kSoft + f * kStiff);
      EXPECT_NEAR(mixed / soft, expected, 0.02 * expected) << to_string(backend) << " f " << f;
    }
  }
}

/// A 16 × 4 × 4 voxel column (1 mm voxels): density 1, material weights from segment's channels,
/// channel 3 (cortical bone) in x < 8, channel 0 (soft tissue) beyond, a graded voxel layer
/// between.
VoxelVolume bone_and_soft_volume() {
  VolumeGeometry g;
  g.dims = {16, 4, 4};
  g.spacing = {1, 1, 1};
  VoxelVolume v(g, true);
  for (int z = 0; z < 4; ++z)
    for (int y = 0; y < 4; ++y)
      for (int x = 0; x < 16; ++x) {
        const std::size_t i = v.index(x, y, z);
        v.density_data()[i] = 1.0f;
        const std::uint8_t bone = x < 7 ? 255 : (x == 7 ? 128 : 0);
        v.material_weight_data()[i] = {static_cast<std::uint8_t>(255 - bone), 0, 0, bone};
      }
  return v;
}

TEST(CrmsPalette, VolumeWeightsGiveBlendsAndABlockIsStifferWhereBoneIs) {
  VolumeLatticeOptions o;
  o.node_spacing_voxels = 2;
  o.material_blends = true;
  o.channel_material = {0, 0, 0, 1};  // channel 3 → the stiff entry
  o.channel_density_g_per_mm3 = {1.0e-3, 1.0e-3, 1.0e-3, 1.9e-3};
  const Lattice built = build_lattice_from_volume(bone_and_soft_volume(), o);
  // Node cells: x ∈ [0,2) … [14,16); cell 3 = voxels 6–7 holds (255 + 128)/2 of bone.
  const LatticeGeometry& g = built.geometry();
  EXPECT_TRUE(built.material(g.index(0, 0, 0)).pure());
  EXPECT_EQ(built.material(g.index(0, 0, 0)).entry(0), 1);
  EXPECT_EQ(built.material(g.index(7, 0, 0)).entry(0), 0);
  const MaterialBlend graded = built.material(g.index(3, 0, 0));
  EXPECT_EQ(graded.entry(0), 1);
  EXPECT_NEAR(graded.weight_of(0), (255.0 + 128.0) / 2.0, 1.0);
  EXPECT_GT(built.mass(g.index(0, 0, 0)), 1.8f * built.mass(g.index(7, 0, 0)));

  for (Backend backend : available_backends()) {
    Lattice l = built;
    fix_nodes_behind_plane(l, {0.6, 0, 0}, {1, 0, 0});
    const auto far = nodes_where(l, [](Vec3d p) { return p.x > 14; });
    Solver s(std::move(l), palette_config(backend));
    std::vector<Vec3f> forces(far.size(), Vec3f{40, 0, 0});
    s.set_external_forces(far, forces);
    const double dt = 0.9 * s.stable_dt();
    s.step(static_cast<int>(0.15 / dt), dt);
    ASSERT_TRUE(assert_finite(s));
    // Strain of the bone half (x cells 0–3) against the soft half (cells 4–7) under the same
    // force: the ratio of their Young's moduli.
    const auto u = s.displacements();
    auto ux = [&](int i) {
      double sum = 0;
      for (int k = 0; k < 2; ++k)
        for (int j = 0; j < 2; ++j) sum += static_cast<double>(u[g.index(i, j, k)].x);
      return sum / 4;
    };
    const double bone_strain = (ux(2) - ux(0)) / 2.0, soft_strain = (ux(7) - ux(5)) / 2.0;
    ASSERT_GT(soft_strain, 0) << to_string(backend);
    EXPECT_NEAR(soft_strain / bone_strain, kStiff / kSoft, 0.1 * kStiff / kSoft)
        << to_string(backend);
  }
}

TEST(CrmsPalette, PerMaterialAnisotropyAxis) {
  for (Backend backend : available_backends()) {
    SolverConfig c = palette_config(backend);
    c.effects.anisotropy.enabled = true;
    c.effects.anisotropy.stiffness_factor = 1;  // the effect's own: isotropic
    c.materials[1] = c.materials[0];
    c.materials[1].anisotropy_axis = {0, 1, 0};  // entry 1: fibres along y, 3× stiffer
    c.materials[1].anisotropy_factor = 3;
    const double fibre_x = block_displacement(backend, MaterialBlend::single(1), 0, &c);
    const double fibre_y = block_displacement(backend, MaterialBlend::single(1), 1, &c);
    const double plain_x = block_displacement(backend, MaterialBlend::single(0), 0, &c);
    const double plain_y = block_displacement(backend, MaterialBlend::single(0), 1, &c);
    ASSERT_GT(fibre_y, 0) << to_string(backend);
    EXPECT_NEAR(fibre_x / fibre_y, 3.0, 0.15) << to_string(backend);
    EXPECT_NEAR(plain_x / plain_y, 1.0, 0.02) << to_string(backend);
  }
}

/// A free 10 × 3 × 3 mm bar (no anchors, no gravity) whose rest shape stretches by `stretch`
/// along x between the keyframes at t0 and t1.
SolverConfig stretching_keyframes(Backend backend, const Lattice& l, double stretch, double t0,
                                  double t1) {
  SolverConfig c = palette_config(backend, 1e-3);
  c.materials.resize(1);
  c.effects.animation.enabled = true;
  RestKeyframe start, end;
  start.time_s = t0;
  end.time_s = t1;
  for (std::int64_t n = 0; n < l.node_count(); ++n) {
    const Vec3d p = l.geometry().rest_position(n);
    start.rest_displacement_mm.push_back({0, 0, 0});
    end.rest_displacement_mm.push_back({static_cast<float>(stretch * (p.x - 5.0)), 0, 0});
  }
  c.effects.animation.rest_keyframes = {start, end};
  return c;
}

double bar_length(const Solver& s) {
  const auto p = s.positions();
  double lo = 1e9, hi = -1e9;
  for (const Vec3f& q : p) {
    lo = std::min(lo, static_cast<double>(q.x));
    hi = std::max(hi, static_cast<double>(q.x));
  }
  return hi - lo;
}

TEST(CrmsAnimation, RestShapeReachesTheKeyframe) {
  for (Backend backend : available_backends()) {
    const Lattice l = box({10, 3, 3}, 1);
    const double rest = bar_length(Solver(box({10, 3, 3}, 1), palette_config(backend)));
    Solver s(l, stretching_keyframes(backend, l, 0.2, 0.01, 0.03));
    const double dt = 0.9 * s.stable_dt();
    s.step(static_cast<int>(0.009 / dt), dt);
    EXPECT_NEAR(bar_length(s), rest, 1e-3 * rest) << "before the first keyframe";
    s.step(static_cast<int>(0.15 / dt), dt);
    ASSERT_TRUE(assert_finite(s));
    EXPECT_NEAR(bar_length(s), 1.2 * rest, 0.02 * rest) << to_string(backend);
    EXPECT_EQ(s.active_effects(), std::vector<std::string>{"animation"});
  }
}

TEST(CrmsAnimation, MaterialTrackMovesTheWeightsToItsEntry) {
  for (Backend backend : available_backends()) {
    Lattice l = box({4, 3, 3}, 1);
    SolverConfig c = palette_config(backend);
    c.effects.animation.enabled = true;
    MaterialTrack track;
    track.start_s = 0.01;
    track.end_s = 0.02;
    track.entry = 1;
    track.nodes = nodes_where(l, [](Vec3d p) { return p.x > 2; });
    c.effects.animation.material_tracks = {track};
    Solver s(std::move(l), c);
    const double dt = 0.9 * s.stable_dt();  // the estimate holds for the track's target too
    auto run_to = [&](double t) {
      while (s.time_s() + 0.5 * dt < t) s.step(1, dt);
    };
    const std::int64_t n = track.nodes.front();
    auto weight_of_entry_1 = [&] {
      const MaterialBlend b = s.lattice().material(n);
      for (int k = 0; k < 4; ++k)
        if (b.entry(k) == 1) return static_cast<double>(b.weight_of(k));
      return 0.0;
    };
    run_to(5e-3);  // before the track
    EXPECT_EQ(weight_of_entry_1(), 0.0);
    run_to(15e-3);  // half way (the blend is set at the start of each step call)
    EXPECT_NEAR(weight_of_entry_1(), 0.5 * 255, 4.0) << to_string(backend);
    run_to(25e-3);  // done
    EXPECT_TRUE(s.lattice().material(n).pure());
    EXPECT_EQ(s.lattice().material(n).entry(0), 1);
    EXPECT_TRUE(assert_finite(s));
  }
}

TEST(CrmsAnimation, CutTriggerSwitchesTheRegionToItsPaletteEntry) {
  for (Backend backend : available_backends()) {
    // A cantilever under gravity; its tip region is an "artery" that goes flaccid once cut.
    auto sag = [&](bool cut) {
      Lattice l = box({10, 3, 3}, 1);
      fix_nodes_behind_plane(l, {0.6, 0, 0}, {1, 0, 0});
      for (std::int64_t n = 0; n < l.node_count(); ++n) l.set_material(n, 1);
      SolverConfig c = palette_config(backend, 5e-3);
      c.gravity = {0, 0, -9810};
      c.effects.animation.enabled = true;
      CutTrigger trigger;
      trigger.name = "artery";
      trigger.entry = 2;
      trigger.nodes = nodes_where(l, [](Vec3d p) { return p.x > 3; });
      const std::int64_t far_corner = trigger.nodes.back();
      c.effects.animation.cut_triggers = {trigger};
      Solver s(std::move(l), c);
      if (cut) s.delete_nodes({far_corner});  // a nick at the tip's corner
      const auto tip = nodes_where(s.lattice(), [](Vec3d p) { return p.x > 9.4; });
      EXPECT_EQ(s.fired_triggers().size(), cut ? 1u : 0u);
      if (cut) {
        EXPECT_EQ(s.fired_triggers().front(), "artery");
        EXPECT_EQ(s.lattice().material(tip.front()).entry(0), 2);
      }
      const double dt = 0.9 * s.stable_dt();
      s.step(static_cast<int>(0.1 / dt), dt);
      EXPECT_TRUE(assert_finite(s));
      return -mean_displacement(s, tip, 2);
    };
    const double intact = sag(false), severed = sag(true);
    ASSERT_GT(intact, 0) << to_string(backend);
    EXPECT_GT(severed, 3.0 * intact) << to_string(backend);  // 20× softer over most of its length
  }
}

TEST(CrmsTearing, NodeMaskingMasksOverloadedNodesAtTheThresholdNotBefore) {
  for (Backend backend : available_backends()) {
    for (double strain : {0.1, 0.3}) {
      Lattice l = box({10, 3, 3}, 1);
      fix_nodes_behind_plane(l, {0.6, 0, 0}, {1, 0, 0});
      const auto far = nodes_where(l, [](Vec3d p) { return p.x > 9.4; });
      SolverConfig c = palette_config(backend);
      c.materials.resize(1);
      c.effects.tearing.enabled = true;
      c.effects.tearing.strain_threshold = 10;  // springs alone never tear here
      // ks·ε with ks = E·h² = 10e3 µN per unit strain: 2000 µN is ε = 0.2.
      c.effects.tearing.node_force_threshold_un = 2000;
      Solver s(std::move(l), c);
      auto stretched = [&](Vec3d p) { return Vec3d{0.5 + (1 + strain) * (p.x - 0.5), p.y, p.z}; };
      deform(s, stretched);
      std::vector<Vec3d> targets;
      for (std::int64_t n : far)
        targets.push_back(stretched(s.lattice().geometry().rest_position(n)));
      s.constrain_nodes(far, targets);
      const double dt = 0.9 * s.stable_dt();
      s.step(100, dt);
      const std::int64_t torn = s.torn_springs();
      if (strain < 0.2) {
        EXPECT_EQ(torn, 0) << to_string(backend);
      } else {
        // Whole nodes go: every spring of a masked node breaks, far more than one per node.
        EXPECT_GE(torn, 9 * 3) << to_string(backend);
      }
      s.release_nodes(far);
      s.step(2000, dt);
      EXPECT_TRUE(assert_finite(s)) << to_string(backend) << " strain " << strain;
    }
  }
}

TEST(CrmsEffects, CpuAndCudaAgreeWithPaletteAnimationAndNodeMasking) {
  if (!cuda_status().available) GTEST_SKIP() << "no CUDA device: " << cuda_status().reason;
  std::vector<std::vector<Vec3f>> result;
  std::vector<std::int64_t> torn;
  for (Backend backend : {Backend::kCpu, Backend::kCuda}) {
    Lattice l = box({8, 6, 5}, 1);
    fix_nodes_behind_plane(l, {0.6, 0, 0}, {1, 0, 0});
    for (std::int64_t n = 0; n < l.node_count(); ++n) {
      const Vec3d p = l.geometry().rest_position(n);
      l.set_material(n, mix(0, 1, std::clamp((p.y - 1.0) / 4.0, 0.0, 1.0)));
    }
    SolverConfig c = palette_config(backend, 5e-4);
    c.gravity = {0, 0, -9810};
    c.materials[1].anisotropy_axis = {1, 0, 1};
    c.materials[1].anisotropy_factor = 2;
    c.materials[1].tear_strain = 0.3;
    c.effects.anisotropy.enabled = true;
    c.effects.plasticity.enabled = true;
    c.effects.tearing.enabled = true;
    c.effects.tearing.strain_threshold = 0.6;
    c.effects.tearing.node_force_threshold_un = 15000;
    c.effects.animation.enabled = true;
    RestKeyframe key;
    key.time_s = 0.002;
    for (std::int64_t n = 0; n < l.node_count(); ++n) {
      const Vec3d p = l.geometry().rest_position(n);
      key.rest_displacement_mm.push_back({0, 0, static_cast<float>(0.05 * (p.z - 2.5))});
    }
    c.effects.animation.rest_keyframes = {key};
    MaterialTrack track;
    track.start_s = 0.0;
    track.end_s = 0.002;
    track.entry = 2;
    track.nodes = nodes_where(l, [](Vec3d p) { return p.x > 6; });
    c.effects.animation.material_tracks = {track};
    Solver s(std::move(l), c);
    deform(s, test::stretch_far_end_compress_rest);
    const double dt = 0.5 * s.stable_dt();
    for (int i = 0; i < 20; ++i) s.step(50, dt);
    ASSERT_TRUE(assert_finite(s));
    result.push_back(s.positions());
    torn.push_back(s.torn_springs());
  }
  EXPECT_EQ(torn[0], torn[1]);
  EXPECT_GT(torn[0], 0);
  EXPECT_TRUE(test::assert_same_positions(result[0], result[1], 1e-4));
}

/// The new effects through the stability suite's hard cases (CPU, and CUDA where present):
/// a blended palette with per-material anisotropy and tear strains, a held rest keyframe and node
/// masking; compressed to 20 %, twisted 180° and stretched 3×, then released. Finite, and the
/// energy (with the rest offsets' potential) never above its start.
TEST(CrmsEffectsRobustness, PaletteAnimationAndNodeMaskingHardCases) {
  struct Case {
    const char* name;
    Vec3d size;
    Vec3d (*map)(Vec3d);
  };
  const Case cases[] = {
      {"compress",
       {6, 6, 6},
       [](Vec3d p) {
         return Vec3d{0.5 + 0.2 * (p.x - 0.5), p.y, p.z};
       }},
      {"twist",
       {16, 4, 4},
       [](Vec3d p) {
         const double a = M_PI * (p.x - 0.5) / 15.0, y = p.y - 2, z = p.z - 2;
         return Vec3d{p.x, 2 + y * std::cos(a) - z * std::sin(a),
                      2 + y * std::sin(a) + z * std::cos(a)};
       }},
      {"stretch",
       {10, 3, 3},
       [](Vec3d p) {
         return Vec3d{0.5 + 3.0 * (p.x - 0.5), p.y, p.z};
       }},
  };
  for (Backend backend : available_backends())
    for (const Case& hard : cases) {
      Lattice l = box(hard.size, 1);
      fix_nodes_behind_plane(l, {0.6, 0, 0}, {1, 0, 0});
      for (std::int64_t n = 0; n < l.node_count(); ++n) l.set_material(n, mix(0, 1, (n % 7) / 6.0));
      SolverConfig c = palette_config(backend, 2e-4);
      c.materials[1].anisotropy_axis = {1, 1, 0};
      c.materials[1].anisotropy_factor = 4;
      c.materials[1].tear_strain = 1.5;
      c.effects.anisotropy.enabled = true;
      c.effects.tearing.enabled = true;
      c.effects.tearing.strain_threshold = 2.0;
      c.effects.tearing.node_force_threshold_un = 1e5;
      c.effects.animation.enabled = true;
      RestKeyframe key;  // held from t = 0: a static rest shape, so energy must not grow
      for (std::int64_t n = 0; n < l.node_count(); ++n) {
        const Vec3d p = l.geometry().rest_position(n);
        key.rest_displacement_mm.push_back({static_cast<float>(0.1 * (p.x - 0.5)), 0, 0});
      }
      c.effects.animation.rest_keyframes = {key};
      Solver s(std::move(l), c);
      deform(s, hard.map);
      const double e0 = s.energy().total_nj();
      const auto energy = run_recording_energy(s, 40, 100, 0.9 * s.stable_dt());
      EXPECT_TRUE(assert_finite(s)) << to_string(backend) << " " << hard.name;
      EXPECT_TRUE(assert_energy_bounded(energy, e0 * 1.02 + 1e-9))
          << to_string(backend) << " " << hard.name;
    }
}

TEST(CrmsEffectsRobustness, BadPaletteAndAnimationInputIsRejectedNamingTheField) {
  auto message = [](SolverConfig c, Lattice l) {
    try {
      Solver s(std::move(l), c);
    } catch (const Error& err) {
      return std::string(err.what());
    }
    return std::string();
  };
  SolverConfig c = palette_config(Backend::kCpu);
  Lattice l = box({3, 3, 3}, 1);
  l.set_material(0, make_material_blend({0, 5, 0, 0}, {0.5, 0.5, 0, 0}));
  EXPECT_NE(message(c, l).find("uses material 5"), std::string::npos);

  SolverConfig anim = palette_config(Backend::kCpu);
  anim.effects.animation.enabled = true;
  RestKeyframe key;
  key.rest_displacement_mm.assign(3, Vec3f{0, 0, 0});
  anim.effects.animation.rest_keyframes = {key};
  EXPECT_NE(message(anim, box({3, 3, 3}, 1)).find("expected 27"), std::string::npos);

  anim.effects.animation.rest_keyframes.clear();
  MaterialTrack track;
  track.entry = 7;
  anim.effects.animation.material_tracks = {track};
  EXPECT_NE(message(anim, box({3, 3, 3}, 1)).find("material_tracks[0].entry"), std::string::npos);

  SolverConfig one = palette_config(Backend::kCpu);
  one.materials.resize(1);
  one.effects.animation.enabled = true;
  CutTrigger trigger;
  trigger.nodes = {0};
  one.effects.animation.cut_triggers = {trigger};
  EXPECT_NE(message(one, box({3, 3, 3}, 1)).find("heterogeneous palette"), std::string::npos);

  SolverConfig bad_material = palette_config(Backend::kCpu);
  bad_material.materials[1].anisotropy_factor = 2;  // no axis
  EXPECT_NE(message(bad_material, box({3, 3, 3}, 1)).find("anisotropy_axis"), std::string::npos);
}

}  // namespace
}  // namespace tsf::crms
