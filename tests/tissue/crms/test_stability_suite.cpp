// The CRMS stability suite (docs/crms.md, "Stability"): hard cases on every available backend, each
// asserting no NaN/Inf, energy bounded by what the scene put in (no energy from nowhere) and, where
// the scene is released, recovery of the rest shape. Lattices are small so that the CPU part stays
// fast.
#include <gtest/gtest.h>

#include <cmath>

#include "physics_assertions.h"

namespace tsf::crms {
namespace {

using test::assert_energy_bounded;
using test::assert_finite;
using test::assert_rest_shape_recovered;
using test::available_backends;
using test::box;
using test::nodes_where;
using test::run_recording_energy;

SolverConfig base_config(Backend backend, double damping_time = 2e-4) {
  SolverConfig c;
  c.backend = backend;
  c.materials = {test::soft_material(10e3, damping_time)};
  return c;
}

using test::deform;

/// Energy bound for a released scene: what it started with, plus what the velocity limit
/// allows the kinetic energy to be when a scene runs beyond the stable step.
double released_energy_bound(double e0) {
  return e0 * 1.02 + 1e-9;
}

TEST(CrmsStability, LatticeAtRestStaysAtRest) {
  // A voxel-built lattice (irregular surface, partial cells, anchors) with no load: after 1e5
  // steps no node has moved by 1e-6 of the spacing.
  VolumeGeometry g;
  g.dims = {10, 8, 8};
  g.spacing = {0.5, 0.5, 0.7};
  VoxelVolume vol(g);
  for (int k = 0; k < 8; ++k)
    for (int j = 0; j < 8; ++j)
      for (int i = 0; i < 10; ++i) {
        const double r = std::hypot(i - 4.5, j - 3.5, (k - 3.5) * 1.4);
        vol.density_data()[vol.index(i, j, k)] = static_cast<float>(std::clamp(5.0 - r, 0.0, 1.0));
      }
  for (Backend backend : available_backends()) {
    VolumeLatticeOptions o;
    o.node_spacing_voxels = 2;
    Lattice l = build_lattice_from_volume(vol, o);
    fix_nodes_behind_plane(l, {0, 0, 1.2}, {0, 0, 1});
    Solver s(std::move(l), base_config(backend));
    s.step(100000, 0.9 * s.stable_dt());
    EXPECT_TRUE(assert_finite(s));
    EXPECT_LT(test::max_rest_deviation(s), 1e-6) << to_string(backend);
  }
}

TEST(CrmsStability, CompressTo20PercentAndRelease) {
  for (Backend backend : available_backends()) {
    Lattice l = box({6, 6, 6}, 1);
    fix_nodes_behind_plane(l, {0, 0, 0.6}, {0, 0, 1});
    Solver s(std::move(l), base_config(backend));
    deform(s, [](Vec3d p) { return Vec3d{p.x, p.y, 0.5 + 0.2 * (p.z - 0.5)}; });
    const double e0 = s.energy().total_nj();
    const auto energy = run_recording_energy(s, 60, 100, 0.9 * s.stable_dt());
    EXPECT_TRUE(assert_finite(s));
    EXPECT_TRUE(assert_energy_bounded(energy, released_energy_bound(e0)));
    EXPECT_TRUE(assert_rest_shape_recovered(s, 1e-3)) << to_string(backend);
  }
}

TEST(CrmsStability, Twist180DegreesAndRelease) {
  for (Backend backend : available_backends()) {
    Lattice l = box({16, 4, 4}, 1);
    fix_nodes_behind_plane(l, {0.6, 0, 0}, {1, 0, 0});
    Solver s(std::move(l), base_config(backend));
    // Cross-sections turned about the beam axis in proportion to x: 180° at the free end.
    deform(s, [](Vec3d p) {
      const double a = M_PI * (p.x - 0.5) / 15.0;
      const double y = p.y - 2, z = p.z - 2;
      return Vec3d{p.x, 2 + y * std::cos(a) - z * std::sin(a),
                   2 + y * std::sin(a) + z * std::cos(a)};
    });
    const double e0 = s.energy().total_nj();
    const auto energy = run_recording_energy(s, 100, 200, 0.9 * s.stable_dt());
    EXPECT_TRUE(assert_finite(s));
    EXPECT_TRUE(assert_energy_bounded(energy, released_energy_bound(e0)));
    // The torsional mode is the slowest to decay (τ = 0.2 ms damps it lightly).
    EXPECT_TRUE(assert_rest_shape_recovered(s, 1e-2)) << to_string(backend);
  }
}

TEST(CrmsStability, Stretch3xAndRelease) {
  for (Backend backend : available_backends()) {
    Lattice l = box({10, 3, 3}, 1);
    fix_nodes_behind_plane(l, {0.6, 0, 0}, {1, 0, 0});
    Solver s(std::move(l), base_config(backend));
    deform(s, [](Vec3d p) { return Vec3d{0.5 + 3.0 * (p.x - 0.5), p.y, p.z}; });
    const double e0 = s.energy().total_nj();
    const auto energy = run_recording_energy(s, 60, 100, 0.9 * s.stable_dt());
    EXPECT_TRUE(assert_finite(s));
    EXPECT_TRUE(assert_energy_bounded(energy, released_energy_bound(e0)));
    EXPECT_TRUE(assert_rest_shape_recovered(s, 1e-3)) << to_string(backend);
  }
}

TEST(CrmsStability, StiffInclusion100xStifferUnderGravityAndCompression) {
  for (Backend backend : available_backends()) {
    Lattice l = box({7, 7, 7}, 1);
    for (std::int64_t n = 0; n < l.node_count(); ++n) {
      const Vec3d p = l.geometry().rest_position(n);
      if (std::fabs(p.x - 3.5) < 1.1 && std::fabs(p.y - 3.5) < 1.1 && std::fabs(p.z - 3.5) < 1.1)
        l.set_material(n, 1);
    }
    fix_nodes_behind_plane(l, {0, 0, 0.6}, {0, 0, 1});
    SolverConfig c = base_config(backend);
    // Damping times chosen so that neither material's highest mode is heavily overdamped (which
    // would shrink the stable step) while the soft matrix's slow modes still settle.
    c.materials = {test::soft_material(10e3, 2e-3), test::soft_material(1e6, 2e-5)};
    c.gravity = {0, 0, -9810};
    Solver s(std::move(l), c);
    // 20% compression of the whole block, inclusion included, then released under gravity.
    deform(s, [](Vec3d p) { return Vec3d{p.x, p.y, 0.5 + 0.8 * (p.z - 0.5)}; });
    const double e0 = s.energy().total_nj();
    const double dt = 0.9 * s.stable_dt();
    // Settles towards the sag under gravity: a second run from rest is the reference shape.
    Solver ref(Lattice(s.lattice()), c);
    auto distance = [&] {
      const auto a = s.displacements(), b = ref.displacements();
      double worst = 0;
      for (std::size_t n = 0; n < a.size(); ++n)
        worst = std::max(worst, length(to_double(a[n]) - to_double(b[n])));
      return worst;
    };
    const auto energy = run_recording_energy(s, 20, 200, dt);
    ref.step(20 * 200, dt);
    EXPECT_TRUE(assert_finite(s));
    EXPECT_TRUE(assert_energy_bounded(energy, released_energy_bound(e0)));
    EXPECT_LT(distance(), 1e-3) << to_string(backend);
  }
}

TEST(CrmsStability, TimeStepBelowAndAboveTheEstimate) {
  for (Backend backend : available_backends()) {
    for (double factor : {0.9, 1.5}) {
      Lattice l = box({6, 6, 6}, 1);
      fix_nodes_behind_plane(l, {0, 0, 0.6}, {0, 0, 1});
      SolverConfig c = base_config(backend);
      c.stability.kinetic_damping = 1e-3;
      Solver s(std::move(l), c);
      deform(s, [](Vec3d p) {
        return Vec3d{p.x + 0.1 * (p.z - 0.5), p.y, 0.5 + 0.9 * (p.z - 0.5)};
      });
      const double e0 = s.energy().total_nj();
      const double dt = factor * s.stable_dt();
      const auto energy = run_recording_energy(s, 80, 100, dt);
      EXPECT_TRUE(assert_finite(s)) << factor;
      if (factor < 1) {
        EXPECT_TRUE(assert_energy_bounded(energy, released_energy_bound(e0)));
        EXPECT_TRUE(assert_rest_shape_recovered(s, 1e-2));
      } else {
        // Beyond the bound the highest modes grow until the velocity limit holds them: kinetic
        // energy can reach ½·M·v_max² but no more.
        const double v_max = 0.25 * 1.0 / dt;
        const double bound = e0 + 0.5 * s.lattice().total_mass() * v_max * v_max;
        EXPECT_TRUE(assert_energy_bounded(energy, bound)) << to_string(backend);
      }
    }
  }
}

TEST(CrmsStability, OneFrameDropOfTenTimesTheStep) {
  for (Backend backend : available_backends()) {
    Lattice l = box({8, 4, 4}, 1);
    fix_nodes_behind_plane(l, {0.6, 0, 0}, {1, 0, 0});
    SolverConfig c = base_config(backend);
    c.gravity = {0, 0, -9810};
    Solver s(std::move(l), c);
    const double dt = 0.9 * s.stable_dt();
    s.step(500, dt);
    const double e_before = s.energy().total_nj();
    s.step(1, 10 * dt);  // the dropped frame
    EXPECT_TRUE(assert_finite(s));
    const double v_max = 0.25 / (10 * dt);
    EXPECT_LT(s.energy().total_nj(),
              std::fabs(e_before) + 0.5 * s.lattice().total_mass() * v_max * v_max);
    s.step(20000, dt);
    EXPECT_TRUE(assert_finite(s));
    // Back to the sag it had before the drop (run a reference without the drop).
    Solver ref(Lattice(s.lattice()), c);
    ref.step(20501, dt);
    const auto a = s.displacements(), b = ref.displacements();
    double worst = 0;
    for (std::size_t n = 0; n < a.size(); ++n)
      worst = std::max(worst, static_cast<double>(length(a[n] - b[n])));
    EXPECT_LT(worst, 1e-3) << to_string(backend);
  }
}

TEST(CrmsStability, IsolatedNodesAndTwoNodeFragments) {
  for (Backend backend : available_backends()) {
    // A 7×1×3 row with every other column deleted: singles and a pair.
    Lattice l = box({7, 3, 1}, 1);
    const LatticeGeometry g = l.geometry();
    for (int j = 0; j < 3; ++j) {
      l.set_alive(g.index(1, j, 0), false);
      l.set_alive(g.index(3, j, 0), false);
      l.set_alive(g.index(5, j, 0), false);
    }
    l.set_alive(g.index(0, 1, 0), false);  // (0,0) and (0,2) become single nodes
    SolverConfig c = base_config(backend);
    c.gravity = {0, 0, -9810};
    c.stability.velocity_limit = 0;
    Solver s(std::move(l), c);
    // Stretch the pair (6,0)-(6,1) by 50% and let it fall.
    s.set_node_states({g.index(6, 1, 0)}, {g.rest_position(6, 1, 0) + Vec3d{0, 0.5, 0}},
                      {{0, 0, 0}});
    const double dt = 1e-4;
    s.step(3000, dt);
    EXPECT_TRUE(assert_finite(s));
    const auto p = s.positions();
    const double fall = 0.5 * 9810 * dt * dt * 3000 * 3001;  // symplectic Euler, exact
    EXPECT_NEAR(p[g.index(0, 0, 0)].z, g.rest_position(0, 0, 0).z - fall, 1e-3 * fall);
    // The pair fell as a body and its spring has relaxed back to the rest length.
    const Vec3f a = p[g.index(6, 0, 0)], b = p[g.index(6, 1, 0)];
    EXPECT_NEAR(length(b - a), 1.0, 1e-3);
    EXPECT_NEAR(0.5 * static_cast<double>(a.z + b.z), g.rest_position(6, 0, 0).z - fall,
                1e-3 * fall);
  }
}

TEST(CrmsStability, MillionStepsWithBoundedEnergy) {
  for (Backend backend : available_backends()) {
    Lattice l = box({3, 2, 2}, 1);
    fix_nodes_behind_plane(l, {0.6, 0, 0}, {1, 0, 0});
    SolverConfig c = base_config(backend, 1e-5);
    c.gravity = {0, 0, -9810};
    Solver s(std::move(l), c);
    deform(s, [](Vec3d p) { return Vec3d{p.x, p.y, p.z + 0.3 * (p.x - 0.5)}; });
    const double e0 = s.energy().total_nj();
    const auto energy = run_recording_energy(s, 100, 10000, 0.9 * s.stable_dt());
    EXPECT_EQ(s.steps_done(), 1000000);
    EXPECT_TRUE(assert_finite(s));
    // Bounded by the start, and at the end the sag's energy (negative: gravity did work).
    EXPECT_TRUE(assert_energy_bounded(energy, released_energy_bound(e0)));
    EXPECT_LT(std::fabs(energy[99] - energy[100]), 1e-6 * std::fabs(e0) + 1e-9);
  }
}

}  // namespace
}  // namespace tsf::crms
