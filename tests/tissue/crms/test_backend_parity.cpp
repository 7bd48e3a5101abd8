// CPU vs CUDA: the same scene with the same integrator stays within 1e-4 (relative to the largest
// displacement) after 1,000 steps, for every formulation and effect combination.
#include <gtest/gtest.h>

#include <cmath>

#include "physics_assertions.h"

namespace tsf::crms {
namespace {

std::vector<Vec3f> run(Backend backend, unsigned combo, Integrator integrator) {
  Lattice l = test::box({12, 8, 6}, 1);
  fix_nodes_behind_plane(l, {0.6, 0, 0}, {1, 0, 0});
  const bool hetero = combo & 1, external = combo & 2;
  if (hetero)
    for (std::int64_t n = 0; n < l.node_count(); ++n)
      if (l.geometry().rest_position(n).x > 6) l.set_material(n, 1);
  l.set_alive(l.geometry().index(5, 4, 3), false);
  SolverConfig c;
  c.backend = backend;
  c.integrator = integrator;
  c.angular_form = (combo & 4) ? AngularForm::kCosine : AngularForm::kExact;
  c.angular_reactions = (combo & 8) ? AngularReactions::kSymmetric : AngularReactions::kGather;
  c.materials = {test::soft_material(10e3, 2e-4)};
  if (hetero) c.materials.push_back(test::soft_material(40e3, 2e-4));
  c.gravity = {0, 0, -9810};
  Solver s(std::move(l), c);
  if (external) {
    const auto tip = test::nodes_where(s.lattice(), [](Vec3d p) { return p.x > 11; });
    s.set_external_forces(tip, std::vector<Vec3f>(tip.size(), Vec3f{0, 50, 0}));
  }
  const double dt = 0.5 * s.stable_dt();
  s.step(997, dt);  // not a multiple of the graph size: graphs and single launches both run
  s.step(3, dt);
  EXPECT_FALSE(s.instability().has_value());
  return s.positions();
}

TEST(CrmsBackendParity, CpuAndCudaAgreeAfter1000Steps) {
  if (!cuda_status().available) GTEST_SKIP() << "CUDA parity not run: " << cuda_status().reason;
  const Lattice rest = test::box({12, 8, 6}, 1);
  for (unsigned combo = 0; combo < 16; ++combo)
    for (Integrator integrator : {Integrator::kSymplecticEuler, Integrator::kExplicitEuler}) {
      const auto cpu = run(Backend::kCpu, combo, integrator);
      const auto gpu = run(Backend::kCuda, combo, integrator);
      double diff = 0, scale = 0;
      for (std::size_t n = 0; n < cpu.size(); ++n) {
        diff = std::max(diff, static_cast<double>(length(cpu[n] - gpu[n])));
        scale = std::max(scale, length(to_double(cpu[n]) - rest.geometry().rest_position(n)));
      }
      EXPECT_LE(diff, 1e-4 * scale) << "combo " << combo << " " << to_string(integrator)
                                    << ": max difference " << diff << " mm of " << scale << " mm";
    }
}

}  // namespace
}  // namespace tsf::crms
