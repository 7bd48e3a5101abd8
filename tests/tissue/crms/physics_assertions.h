// Physics assertions and small scene builders for the CRMS tests (iMSTK-style helpers: each
// returns a gtest AssertionResult that says what was wrong, where).
#pragma once

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "tsf/common/cuda_support.h"
#include "tsf/crms/calibration.h"
#include "tsf/crms/lattice_builders.h"
#include "tsf/crms/solver.h"

namespace tsf::crms::test {

/// Every node position and velocity finite, and the solver not halted.
inline ::testing::AssertionResult assert_finite(const Solver& solver) {
  if (solver.instability())
    return ::testing::AssertionFailure() << solver.instability()->describe();
  const auto p = solver.positions();
  const auto v = solver.velocities();
  for (std::size_t n = 0; n < p.size(); ++n)
    if (!std::isfinite(p[n].x) || !std::isfinite(p[n].y) || !std::isfinite(p[n].z) ||
        !std::isfinite(v[n].x) || !std::isfinite(v[n].y) || !std::isfinite(v[n].z))
      return ::testing::AssertionFailure()
             << "node " << n << " is not finite: p = (" << p[n].x << ", " << p[n].y << ", "
             << p[n].z << "), v = (" << v[n].x << ", " << v[n].y << ", " << v[n].z << ")";
  return ::testing::AssertionSuccess();
}

/// Every sample of an energy series is finite and at most `bound` (nJ).
inline ::testing::AssertionResult assert_energy_bounded(const std::vector<double>& energies,
                                                        double bound) {
  for (std::size_t s = 0; s < energies.size(); ++s)
    if (!std::isfinite(energies[s]) || energies[s] > bound)
      return ::testing::AssertionFailure() << "energy sample " << s << " = " << energies[s]
                                           << " nJ exceeds the bound " << bound << " nJ";
  return ::testing::AssertionSuccess();
}

/// Largest distance of an alive node from its rest position, in units of the smallest spacing.
inline double max_rest_deviation(const Solver& solver) {
  const auto u = solver.displacements();
  const Lattice& l = solver.lattice();
  double worst = 0.0;
  for (std::int64_t n = 0; n < l.node_count(); ++n)
    if (l.alive(n)) worst = std::max(worst, std::sqrt(static_cast<double>(dot(u[n], u[n]))));
  return worst / l.geometry().min_spacing();
}

/// The lattice has returned to its rest shape up to a rigid motion? Here anchored scenes are used,
/// so the rest shape itself is the reference.
inline ::testing::AssertionResult assert_rest_shape_recovered(const Solver& solver,
                                                              double tolerance_spacings) {
  const double d = max_rest_deviation(solver);
  if (d <= tolerance_spacings) return ::testing::AssertionSuccess();
  return ::testing::AssertionFailure() << "largest deviation from the rest shape is " << d
                                       << " spacings (tolerance " << tolerance_spacings << ")";
}

/// Runs `frames` × `steps_per_frame` steps, recording total energy after each frame.
inline std::vector<double> run_recording_energy(Solver& solver, int frames, int steps_per_frame,
                                                double dt) {
  std::vector<double> energy;
  energy.reserve(static_cast<std::size_t>(frames) + 1);
  energy.push_back(solver.energy().total_nj());
  for (int f = 0; f < frames; ++f) {
    solver.step(steps_per_frame, dt);
    energy.push_back(solver.energy().total_nj());
  }
  return energy;
}

/// A soft-tissue material: E = 10 kPa, η chosen for damping time τ = η/E, water density.
inline Material soft_material(double youngs_pa = 10e3, double damping_time_s = 2e-4) {
  Material m;
  m.youngs_modulus_pa = youngs_pa;
  m.viscosity_pa_s = youngs_pa * damping_time_s;
  m.density_g_per_mm3 = 1e-3;
  return m;
}

inline Lattice box(Vec3d size_mm, double spacing_mm) {
  BoxLatticeOptions o;
  o.size_mm = size_mm;
  o.spacing_mm = spacing_mm;
  return build_box_lattice(o);
}

/// Node indices whose rest position satisfies `pred`.
template <typename Pred>
std::vector<std::int64_t> nodes_where(const Lattice& lattice, Pred pred) {
  std::vector<std::int64_t> out;
  for (std::int64_t n = 0; n < lattice.node_count(); ++n)
    if (lattice.alive(n) && pred(lattice.geometry().rest_position(n))) out.push_back(n);
  return out;
}

/// The backends to run a backend-dependent test on: always the CPU; CUDA where a device exists.
inline std::vector<Backend> available_backends() {
  std::vector<Backend> b{Backend::kCpu};
  if (cuda_status().available) b.push_back(Backend::kCuda);
  return b;
}

/// Deforms every node's rest position by `map` (Vec3d → Vec3d, mm) and sets that as the state,
/// at rest (zero velocity).
template <typename Map>
void deform(Solver& s, Map map) {
  const Lattice& l = s.lattice();
  std::vector<Vec3f> u(static_cast<std::size_t>(l.node_count())), v(u.size());
  for (std::int64_t n = 0; n < l.node_count(); ++n) {
    const Vec3d p = l.geometry().rest_position(n);
    u[static_cast<std::size_t>(n)] = to_float(map(p) - p);
  }
  s.set_state(u, v);
}

/// CPU and CUDA results agree: every position within `relative` × the largest displacement
/// magnitude of `a` (positions as returned by Solver::positions()).
inline ::testing::AssertionResult assert_same_positions(const std::vector<Vec3f>& a,
                                                        const std::vector<Vec3f>& b,
                                                        double relative) {
  if (a.size() != b.size())
    return ::testing::AssertionFailure() << a.size() << " against " << b.size() << " nodes";
  double scale = 0, worst = 0;
  std::size_t worst_node = 0;
  for (std::size_t n = 0; n < a.size(); ++n) {
    scale = std::max(scale, static_cast<double>(std::sqrt(dot(a[n], a[n]))));
    const Vec3f d = a[n] - b[n];
    const double e = static_cast<double>(std::sqrt(dot(d, d)));
    if (e > worst) {
      worst = e;
      worst_node = n;
    }
  }
  if (worst < relative * scale) return ::testing::AssertionSuccess();
  return ::testing::AssertionFailure() << "node " << worst_node << " differs by " << worst
                                       << " mm, more than " << relative << " × " << scale;
}

/// The parity scenes' deformation: the far end (x > 6.5 mm) stretched by 100% (it tears at
/// once), the rest compressed by 10%.
inline Vec3d stretch_far_end_compress_rest(Vec3d p) {
  const double x = p.x < 6.5 ? 0.5 + 0.9 * (p.x - 0.5) : 5.9 + 2.0 * (p.x - 6.5);
  return Vec3d{x, p.y, p.z};
}

/// The backend-parity scene: a 12 × 8 × 6 mm box at 1 mm, held behind x = 0.6 mm, one dead node;
/// `combo` bits: 1 a second, stiffer material beyond x = 6, 2 a constant load on the tip (added by
/// with_parity_loads once the solver exists), 4 the cosine angular form, 8 symmetric reactions.
inline std::pair<Lattice, SolverConfig> parity_scene(Backend backend, unsigned combo) {
  Lattice l = box({12, 8, 6}, 1);
  fix_nodes_behind_plane(l, {0.6, 0, 0}, {1, 0, 0});
  const bool hetero = combo & 1;
  if (hetero)
    for (std::int64_t n = 0; n < l.node_count(); ++n)
      if (l.geometry().rest_position(n).x > 6) l.set_material(n, 1);
  l.set_alive(l.geometry().index(5, 4, 3), false);
  SolverConfig c;
  c.backend = backend;
  c.angular_form = (combo & 4) ? AngularForm::kCosine : AngularForm::kExact;
  c.angular_reactions = (combo & 8) ? AngularReactions::kSymmetric : AngularReactions::kGather;
  c.materials = {soft_material(10e3, 2e-4)};
  if (hetero) c.materials.push_back(soft_material(40e3, 2e-4));
  return {std::move(l), c};
}

/// The parity scene's tip load (combo bit 2): 50 µN along y on the nodes beyond x = 11 mm.
inline void with_parity_loads(Solver& s, unsigned combo) {
  if (!(combo & 2)) return;
  const auto tip = nodes_where(s.lattice(), [](Vec3d p) { return p.x > 11; });
  s.set_external_forces(tip, std::vector<Vec3f>(tip.size(), Vec3f{0, 50, 0}));
}

/// A material with Poisson ratio ν (the volumetric term on): E = 10 kPa unless given.
inline Material poisson_material(double nu, double youngs_pa = 10e3, double damping_time_s = 2e-4) {
  Material m = soft_material(youngs_pa, damping_time_s);
  m.poisson_ratio = nu;
  return m;
}

/// The volumetric term's force on every node at the CPU solver's current state (µN; velocities
/// as they are: their damping included), through the passes' own functions (volume_term.h).
inline std::vector<Vec3f> volume_forces(const Solver& s) {
  const LatticeView lat = s.lattice_view();
  const ConstStateView st = s.state_view();
  const LatticeGeometry& g = s.lattice().geometry();
  const auto count = static_cast<std::size_t>(lat.count);
  const VolumeParameters vp = calibrate_volume(s.config().materials);
  std::vector<float> terms[9];
  float* pointers[9];
  for (int t = 0; t < 9; ++t) {
    terms[t].assign(count, 0.0f);
    pointers[t] = terms[t].data();
  }
  for (std::size_t n = 0; n < count; ++n) {
    const Int3 c = g.coordinates(static_cast<std::int64_t>(n));
    cube_volume_terms(lat, st, vp, static_cast<std::int64_t>(n), c.x, c.y, c.z, pointers);
  }
  std::vector<Vec3f> force(count);
  for (std::size_t n = 0; n < count; ++n) {
    const Int3 c = g.coordinates(static_cast<std::int64_t>(n));
    force[n] = volume_force(lat, pointers, static_cast<std::int64_t>(n), c.x, c.y, c.z);
  }
  return force;
}

}  // namespace tsf::crms::test
