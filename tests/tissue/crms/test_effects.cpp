// The optional CRMS effects (docs/effects.md): each effect's defining behaviour, every effect
// through the stability suite's hard cases, and CPU vs CUDA parity with all effects on. Every test
// runs on the CPU and, where a device exists, on CUDA.
#include <gtest/gtest.h>

#include <cmath>
#include <numeric>

#include "physics_assertions.h"
#include "tsf/common/error.h"

namespace tsf::crms {
namespace {

using test::assert_energy_bounded;
using test::assert_finite;
using test::available_backends;
using test::box;
using test::nodes_where;
using test::run_recording_energy;

SolverConfig config_for(Backend backend, double damping_time = 1e-3) {
  SolverConfig c;
  c.backend = backend;
  c.materials = {test::soft_material(10e3, damping_time)};
  return c;
}

using test::deform;

/// Mean displacement along `axis` of the nodes in `nodes`, mm.
double mean_displacement(const Solver& s, const std::vector<std::int64_t>& nodes, int axis) {
  const auto u = s.displacements();
  double sum = 0;
  for (std::int64_t n : nodes) sum += static_cast<double>(u[n][axis]);
  return sum / static_cast<double>(nodes.size());
}

/// A bar along x, 10 × 3 × 3 mm at 1 mm, clamped at x = 0.5 (first node layer). Its far face
/// is held at a uniform stretch `strain` for `hold_s`, then released; returns the far face's
/// mean x displacement `settle_s` after the release.
struct BarRun {
  double set_after_release = 0;
  double set_later = 0;
};
BarRun stretch_hold_release(Backend backend, const EffectsConfig& effects, double strain,
                            double hold_s, double settle_s, double later_s = 0) {
  Lattice l = box({10, 3, 3}, 1);
  fix_nodes_behind_plane(l, {0.6, 0, 0}, {1, 0, 0});
  const auto far = nodes_where(l, [](Vec3d p) { return p.x > 9.4; });
  SolverConfig c = config_for(backend);
  c.effects = effects;
  Solver s(std::move(l), c);
  const double dt = 0.9 * s.stable_dt();
  deform(s, [&](Vec3d p) { return Vec3d{0.5 + (1 + strain) * (p.x - 0.5), p.y, p.z}; });
  std::vector<Vec3d> targets;
  for (std::int64_t n : far) {
    const Vec3d p = s.lattice().geometry().rest_position(n);
    targets.push_back({0.5 + (1 + strain) * (p.x - 0.5), p.y, p.z});
  }
  s.constrain_nodes(far, targets);
  s.step(static_cast<int>(hold_s / dt), dt);
  s.release_nodes(far);
  s.step(static_cast<int>(settle_s / dt), dt);
  EXPECT_TRUE(assert_finite(s));
  BarRun r;
  r.set_after_release = mean_displacement(s, far, 0);
  if (later_s > 0) {
    s.step(static_cast<int>(later_s / dt), dt);
    r.set_later = mean_displacement(s, far, 0);
  }
  return r;
}

TEST(CrmsEffects, PlasticPermanentSetAboveThresholdNoneBelow) {
  EffectsConfig e;
  e.plasticity.enabled = true;
  e.plasticity.yield_strain = 0.05;
  e.plasticity.creep_rate = 2000;
  for (Backend backend : available_backends()) {
    // 30% held long enough for full creep: each spring keeps (0.30 − 0.05)·L of plastic
    // offset, so the 9 mm free length keeps a set of about 0.25·9 mm.
    const BarRun above = stretch_hold_release(backend, e, 0.30, 0.02, 0.08);
    const double expected = (0.30 - 0.05) * 9.0;
    EXPECT_GT(above.set_after_release, 0.85 * expected) << to_string(backend);
    EXPECT_LT(above.set_after_release, 1.1 * expected) << to_string(backend);
    // 3% is below the yield strain: the bar returns to its rest shape.
    const BarRun below = stretch_hold_release(backend, e, 0.03, 0.02, 0.08);
    EXPECT_LT(std::abs(below.set_after_release), 1e-3) << to_string(backend);
  }
}

TEST(CrmsEffects, ViscoElasticSetDecaysAtTheRecoveryRate) {
  EffectsConfig e;
  e.plasticity.enabled = true;
  e.plasticity.yield_strain = 0.05;
  e.plasticity.creep_rate = 2000;
  e.plasticity.recovery_rate = 20;  // 1/s: the set falls by e over 50 ms
  for (Backend backend : available_backends()) {
    const BarRun r = stretch_hold_release(backend, e, 0.30, 0.02, 0.03, 0.05);
    ASSERT_GT(r.set_after_release, 0.1) << to_string(backend);
    const double ratio = r.set_later / r.set_after_release;
    EXPECT_NEAR(ratio, std::exp(-20 * 0.05), 0.1 * std::exp(-1.0)) << to_string(backend);
  }
}

/// Static displacement of a 5×5×5 mm block's loaded face under a uniform traction along `axis`
/// (opposite face clamped).
double loaded_face_displacement(Backend backend, const EffectsConfig& effects, int axis,
                                float load_un = 20.0f) {
  Lattice l = box({5, 5, 5}, 1);
  Vec3d normal{0, 0, 0};
  normal[axis] = 1;
  Vec3d point{0.6, 0.6, 0.6};
  fix_nodes_behind_plane(l, point, normal);
  const auto face = nodes_where(l, [&](Vec3d p) { return p[axis] > 4.4; });
  SolverConfig c = config_for(backend, 2e-3);
  c.effects = effects;
  Solver s(std::move(l), c);
  std::vector<Vec3f> forces(face.size(), Vec3f{0, 0, 0});
  for (auto& f : forces) f[axis] = load_un;  // µN per node: 20 µN on a 1 mm² cell, 2e-3 strain
  s.set_external_forces(face, forces);
  const double dt = 0.9 * s.stable_dt();
  s.step(static_cast<int>(0.1 / dt), dt);
  EXPECT_TRUE(assert_finite(s));
  return mean_displacement(s, face, axis);
}

TEST(CrmsEffects, AnisotropicBlockIsStifferAlongItsAxisByTheFactor) {
  EffectsConfig e;
  e.anisotropy.enabled = true;
  e.anisotropy.axis = {2, 0, 0};  // not normalised on purpose
  e.anisotropy.stiffness_factor = 3;
  for (Backend backend : available_backends()) {
    const double along = loaded_face_displacement(backend, e, 0);
    const double across = loaded_face_displacement(backend, e, 1);
    const double plain = loaded_face_displacement(backend, EffectsConfig{}, 0);
    ASSERT_GT(along, 0) << to_string(backend);
    EXPECT_NEAR(across / along, 3.0, 0.05 * 3.0) << to_string(backend);
    EXPECT_NEAR(across / plain, 1.0, 0.01) << to_string(backend);
  }
}

TEST(CrmsEffects, FluidBlockResistsCompressionMoreAndPressureSpreads) {
  for (Backend backend : available_backends()) {
    // Sealed block (no flow): compressing it needs more force with the fluid.
    EffectsConfig fluid;
    fluid.fluid.enabled = true;
    fluid.fluid.bulk_modulus_pa = 20e3;  // 2·E
    const double dry = -loaded_face_displacement(backend, EffectsConfig{}, 2, -20.0f);
    const double wet = -loaded_face_displacement(backend, fluid, 2, -20.0f);
    ASSERT_GT(dry, 0) << to_string(backend);
    ASSERT_GT(wet, 0) << to_string(backend);
    EXPECT_LT(wet, 0.8 * dry) << to_string(backend);

    // A bar squeezed at one end: the pressure reaches the far end over time, and the fluid
    // is conserved.
    fluid.fluid.diffusion_rate = 4000;
    Lattice l = box({12, 3, 3}, 1);
    const auto squeezed = nodes_where(l, [](Vec3d p) { return p.x < 2.6; });
    const std::int64_t far_cube = l.geometry().index(9, 1, 1);
    SolverConfig c = config_for(backend);
    c.effects = fluid;
    Solver s(std::move(l), c);
    std::vector<Vec3d> targets;
    for (std::int64_t n : squeezed) {
      const Vec3d p = s.lattice().geometry().rest_position(n);
      targets.push_back({p.x, 1.5 + 0.8 * (p.y - 1.5), 1.5 + 0.8 * (p.z - 1.5)});
    }
    s.constrain_nodes(squeezed, targets);
    const double dt = 0.9 * s.stable_dt();
    s.step(static_cast<int>(0.0005 / dt), dt);
    const EffectsState early = s.effects_state();
    s.step(static_cast<int>(0.05 / dt), dt);
    const EffectsState late = s.effects_state();
    EXPECT_TRUE(assert_finite(s));
    const float near_p = late.fluid_pressure[s.lattice().geometry().index(0, 1, 1)];
    EXPECT_GT(near_p, 0.0f) << to_string(backend);
    EXPECT_GT(late.fluid_pressure[far_cube], 0.2f * near_p) << to_string(backend);
    EXPECT_GT(late.fluid_pressure[far_cube], 5.0f * std::abs(early.fluid_pressure[far_cube]))
        << to_string(backend);
    double total = 0, magnitude = 0;
    for (float q : late.fluid_content) {
      total += static_cast<double>(q);
      magnitude += static_cast<double>(std::abs(q));
    }
    EXPECT_GT(magnitude, 0.0) << to_string(backend);
    EXPECT_LT(std::abs(total), 1e-3 * magnitude) << to_string(backend);
  }
}

TEST(CrmsEffects, StretchedBarTearsAtTheThresholdNotBefore) {
  EffectsConfig e;
  e.tearing.enabled = true;
  e.tearing.strain_threshold = 0.5;
  for (Backend backend : available_backends()) {
    for (double strain : {0.45, 0.6}) {
      Lattice l = box({10, 3, 3}, 1);
      fix_nodes_behind_plane(l, {0.6, 0, 0}, {1, 0, 0});
      const auto far = nodes_where(l, [](Vec3d p) { return p.x > 9.4; });
      SolverConfig c = config_for(backend);
      c.effects = e;
      Solver s(std::move(l), c);
      auto stretched = [&](Vec3d p) { return Vec3d{0.5 + (1 + strain) * (p.x - 0.5), p.y, p.z}; };
      deform(s, stretched);
      std::vector<Vec3d> targets;
      for (std::int64_t n : far)
        targets.push_back(stretched(s.lattice().geometry().rest_position(n)));
      s.constrain_nodes(far, targets);
      const double dt = 0.9 * s.stable_dt();
      s.step(200, dt);
      if (strain < 0.5) {
        EXPECT_EQ(s.torn_springs(), 0) << to_string(backend);
      } else {
        EXPECT_GT(s.torn_springs(), 0) << to_string(backend);
      }
      s.release_nodes(far);
      s.step(2000, dt);
      EXPECT_TRUE(assert_finite(s)) << to_string(backend) << " strain " << strain;
    }
  }
}

/// The effects one at a time and all together, for the hard cases below (and none: with the
/// volumetric term alone, see released_hard_case).
std::vector<EffectsConfig> effect_sets() {
  std::vector<EffectsConfig> sets(6);
  sets[0].plasticity.enabled = true;
  sets[0].plasticity.recovery_rate = 50;
  sets[1].anisotropy.enabled = true;
  sets[1].anisotropy.axis = {1, 1, 0};
  sets[1].anisotropy.stiffness_factor = 4;
  sets[2].fluid.enabled = true;
  sets[2].fluid.bulk_modulus_pa = 10e3;
  sets[2].fluid.diffusion_rate = 100;
  sets[3].tearing.enabled = true;
  sets[3].tearing.strain_threshold = 1.0;
  sets[4].plasticity = sets[0].plasticity;
  sets[4].anisotropy = sets[1].anisotropy;
  sets[4].fluid = sets[2].fluid;
  sets[4].tearing = sets[3].tearing;
  return sets;
}

/// The volumetric term (ν = 0.45) runs alone (the empty set) and with every other effect.
bool with_volumetric(const EffectsConfig& e) {
  return !e.any() || (e.plasticity.enabled && e.fluid.enabled);
}

SolverConfig with_effects(SolverConfig c, const EffectsConfig& e) {
  c.effects = e;
  if (with_volumetric(e)) c.materials.front().poisson_ratio = 0.45;
  return c;
}

std::string label(const EffectsConfig& e) {
  std::string s;
  for (const auto& n : e.active()) s += n + " ";
  return with_volumetric(e) ? s + "volumetric (ν = 0.45)" : s;
}

/// Runs a released hard case: finite, and the total energy (springs with their effects, fluid,
/// kinetic, gravity) never above what the scene started with.
template <typename Map>
void released_hard_case(Vec3d size, double anchor_x, Map map, int frames) {
  for (Backend backend : available_backends())
    for (const EffectsConfig& e : effect_sets()) {
      Lattice l = box(size, 1);
      fix_nodes_behind_plane(l, {anchor_x, 0, 0}, {1, 0, 0});
      const SolverConfig c = with_effects(config_for(backend, 2e-4), e);
      Solver s(std::move(l), c);
      deform(s, map);
      const double e0 = s.energy().total_nj();
      const auto energy = run_recording_energy(s, frames, 100, 0.9 * s.stable_dt());
      EXPECT_TRUE(assert_finite(s)) << to_string(backend) << " " << label(e);
      EXPECT_TRUE(assert_energy_bounded(energy, e0 * 1.02 + 1e-9))
          << to_string(backend) << " " << label(e);
    }
}

TEST(CrmsEffects, EveryEffectCompressTo20PercentAndRelease) {
  released_hard_case(
      {6, 6, 6}, 0.6,
      [](Vec3d p) {
        return Vec3d{0.5 + 0.2 * (p.x - 0.5), p.y, p.z};
      },
      40);
}

TEST(CrmsEffects, EveryEffectTwist180DegreesAndRelease) {
  released_hard_case(
      {16, 4, 4}, 0.6,
      [](Vec3d p) {
        const double a = M_PI * (p.x - 0.5) / 15.0;
        const double y = p.y - 2, z = p.z - 2;
        return Vec3d{p.x, 2 + y * std::cos(a) - z * std::sin(a),
                     2 + y * std::sin(a) + z * std::cos(a)};
      },
      40);
}

TEST(CrmsEffects, EveryEffectStretch3xAndRelease) {
  released_hard_case(
      {10, 3, 3}, 0.6,
      [](Vec3d p) {
        return Vec3d{0.5 + 3.0 * (p.x - 0.5), p.y, p.z};
      },
      40);
}

TEST(CrmsEffects, EveryEffectTimeStepAboveTheEstimateStaysFinite) {
  // 1.5× the (effect-adjusted) stable estimate with gravity: the velocity limit must keep every
  // effect finite, as it does the core.
  for (Backend backend : available_backends())
    for (const EffectsConfig& e : effect_sets()) {
      Lattice l = box({6, 4, 4}, 1);
      fix_nodes_behind_plane(l, {0.6, 0, 0}, {1, 0, 0});
      SolverConfig c = with_effects(config_for(backend, 2e-4), e);
      c.gravity = {0, 0, -9810};
      Solver s(std::move(l), c);
      s.step(3000, 1.5 * s.stable_dt());
      EXPECT_TRUE(assert_finite(s)) << to_string(backend) << " " << label(e);
    }
}

/// One backend's run of the CPU/CUDA parity tests: the block (anchored at x = 0, gravity) stretched
/// at its far end, 1000 steps at half the stable step.
struct ParityRun {
  std::vector<Vec3f> positions;
  std::int64_t torn = 0;
  EffectsState effects;
  double elastic_nj = 0;
};
ParityRun parity_run(Lattice l, SolverConfig c) {
  fix_nodes_behind_plane(l, {0.6, 0, 0}, {1, 0, 0});
  c.gravity = {0, 0, -9810};
  Solver s(std::move(l), c);
  deform(s, test::stretch_far_end_compress_rest);
  s.step(1000, 0.5 * s.stable_dt());
  EXPECT_TRUE(assert_finite(s)) << to_string(c.backend);
  return {s.positions(), s.torn_springs(), s.effects_state(), s.energy().elastic_nj};
}

TEST(CrmsEffects, CpuAndCudaAgreeWithAllEffectsOn) {
  if (!cuda_status().available) GTEST_SKIP() << "no CUDA device: " << cuda_status().reason;
  EffectsConfig e = effect_sets()[4];
  e.tearing.strain_threshold = 0.4;
  std::vector<ParityRun> runs;
  for (Backend backend : {Backend::kCpu, Backend::kCuda}) {
    SolverConfig c = config_for(backend, 5e-4);
    c.effects = e;
    runs.push_back(parity_run(box({8, 6, 5}, 1), c));
  }
  EXPECT_EQ(runs[0].torn, runs[1].torn);
  EXPECT_GT(runs[0].torn, 0);
  EXPECT_TRUE(test::assert_same_positions(runs[0].positions, runs[1].positions, 1e-4));
  const EffectsState states[2] = {runs[0].effects, runs[1].effects};
  double p_scale = 0, p_worst = 0;
  for (std::size_t n = 0; n < states[0].fluid_pressure.size(); ++n) {
    p_scale = std::max(p_scale, static_cast<double>(std::abs(states[0].fluid_pressure[n])));
    p_worst = std::max(p_worst, static_cast<double>(std::abs(states[0].fluid_pressure[n] -
                                                             states[1].fluid_pressure[n])));
  }
  EXPECT_GT(p_scale, 0.0);
  EXPECT_LT(p_worst, 1e-3 * p_scale);
}

TEST(CrmsEffects, CpuAndCudaAgreeWithTheVolumetricTerm) {
  // Materials with ν (a soft ν = 0.45 and a stiffer ν = 0.3 entry, blended nodes between them),
  // the term's cube pass and kick, with tearing (a cube loses its term as soon as one of its
  // edges tears) and anisotropy (the effect-force array beside the term's forces).
  if (!cuda_status().available) GTEST_SKIP() << "no CUDA device: " << cuda_status().reason;
  std::vector<ParityRun> runs;
  for (Backend backend : {Backend::kCpu, Backend::kCuda}) {
    Lattice l = box({8, 6, 5}, 1);
    for (std::int64_t n = 0; n < l.node_count(); ++n) {
      const double x = l.geometry().rest_position(n).x;
      if (x > 4.6) l.set_material(n, 1);
      if (std::fabs(x - 4.5) < 0.1)
        l.set_material(n, make_material_blend({0, 1, 0, 0}, {0.5, 0.5, 0, 0}));
    }
    SolverConfig c = config_for(backend, 5e-4);
    c.materials = {test::poisson_material(0.45, 10e3, 5e-4),
                   test::poisson_material(0.3, 30e3, 5e-4)};
    c.effects.tearing.enabled = true;
    c.effects.tearing.strain_threshold = 0.4;
    c.effects.anisotropy.enabled = true;
    c.effects.anisotropy.axis = {0, 1, 1};
    c.effects.anisotropy.stiffness_factor = 2;
    runs.push_back(parity_run(std::move(l), c));
  }
  EXPECT_EQ(runs[0].torn, runs[1].torn);
  EXPECT_GT(runs[0].torn, 0);
  EXPECT_TRUE(test::assert_same_positions(runs[0].positions, runs[1].positions, 1e-4));
  EXPECT_NEAR(runs[0].elastic_nj, runs[1].elastic_nj, 1e-3 * std::fabs(runs[0].elastic_nj));
}

TEST(CrmsEffects, DisabledEffectsAllocateNothingAndChangeNothing) {
  for (Backend backend : available_backends()) {
    Lattice a = box({6, 4, 4}, 1), b = box({6, 4, 4}, 1);
    SolverConfig c = config_for(backend);
    c.gravity = {0, 0, -9810};
    Solver plain(std::move(a), c);
    c.effects.fluid.bulk_modulus_pa = 123;  // parameters of effects that stay off
    c.effects.plasticity.yield_strain = 0.01;
    Solver off(std::move(b), c);
    EXPECT_TRUE(off.active_effects().empty());
    EXPECT_EQ(off.bytes_per_node(), plain.bytes_per_node());
    EXPECT_TRUE(off.effects_state().plastic_offset.empty());
    plain.step(500, plain.stable_dt());
    off.step(500, off.stable_dt());
    EXPECT_EQ(plain.positions(), off.positions()) << to_string(backend);
  }
}

TEST(CrmsEffects, ActiveEffectsAndBytesAreReported) {
  SolverConfig c = config_for(Backend::kCpu);
  c.effects = effect_sets()[4];
  Solver s(box({4, 4, 4}, 1), c);
  EXPECT_EQ(s.active_effects(),
            (std::vector<std::string>{"plasticity", "anisotropy", "fluid", "tearing"}));
  SolverConfig plain = config_for(Backend::kCpu);
  Solver p(box({4, 4, 4}, 1), plain);
  // plastic offsets 12 B + fluid 8 B + the effect force 12 B.
  EXPECT_EQ(s.bytes_per_node() - p.bytes_per_node(), 32.0);
}

TEST(CrmsEffects, OutOfRangeParametersAreRejectedNamingTheField) {
  auto message = [](const EffectsConfig& e) {
    SolverConfig c = config_for(Backend::kCpu);
    c.effects = e;
    try {
      Solver s(box({3, 3, 3}, 1), c);
    } catch (const Error& err) {
      return std::string(err.what());
    }
    return std::string();
  };
  EffectsConfig e;
  e.fluid.enabled = true;
  e.fluid.bulk_modulus_pa = -1;
  EXPECT_NE(message(e).find("effects.fluid.bulk_modulus_pa"), std::string::npos) << message(e);
  e = {};
  e.anisotropy.enabled = true;
  e.anisotropy.axis = {0, 0, 0};
  EXPECT_NE(message(e).find("effects.anisotropy.axis"), std::string::npos) << message(e);
  e = {};
  e.plasticity.enabled = true;
  e.plasticity.yield_strain = 0;
  EXPECT_NE(message(e).find("effects.plasticity.yield_strain"), std::string::npos) << message(e);
  e = {};
  e.tearing.enabled = true;
  e.tearing.strain_threshold = std::nan("");
  EXPECT_NE(message(e).find("effects.tearing.strain_threshold"), std::string::npos) << message(e);
  SolverConfig c = config_for(Backend::kCpu);
  c.integrator = Integrator::kImplicitEuler;
  c.effects.tearing.enabled = true;
  EXPECT_THROW(Solver(box({3, 3, 3}, 1), c), Error);
}

}  // namespace
}  // namespace tsf::crms
