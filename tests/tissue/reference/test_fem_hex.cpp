// The hexahedral FEM reference against closed-form solutions: patch tests (uniform strain is
// reproduced exactly), a uniaxial bar (FL/EA, exact), and slender cantilevers against
// Euler–Bernoulli beam theory under a tip load (PL³/3EI) and under self-weight (qL⁴/8EI), which the
// incompatible-mode element must meet within 2% at its finest resolution. Convergence tables are
// printed (docs/accuracy-vs-time.md quotes the report's version of them).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <string>

#include "tsf/common/error.h"
#include "tsf/crms/lattice_builders.h"
#include "tsf/reference/fem_hex.h"

namespace tsf::reference {
namespace {

struct BeamCase {
  double length = 20.0;    ///< mm, free length from the clamp at x = 0
  double thickness = 2.0;  ///< mm, square cross-section
  double youngs = 1e6;     ///< Pa
  double poisson = 0.0;
  double density = 1e-3;  ///< g/mm³
};

/// Tip deflection (mm, downward positive) at the centre of the free end face of a cantilever
/// clamped on its x = 0 face, `across` elements per side, loaded by gravity (self-weight) or by
/// a total tip force P (µN) spread as a uniform shear traction on the end face.
double cantilever_tip(const BeamCase& b, int across, bool self_weight, double tip_force_un,
                      HexFormulation formulation) {
  const double h = b.thickness / across;
  const int along = static_cast<int>(std::lround(b.length / h));
  FemHexModel model(make_box_hex_mesh({along, across, across}, {h, h, h}, {0, 0, 0}),
                    {ElasticMaterial{b.youngs, b.poisson, b.density}});
  model.fix_nodes_in_box({-1e-9, -1, -1}, {1e-9, b.thickness + 1, b.thickness + 1});
  if (self_weight) model.set_gravity({0, 0, -9810.0});
  if (tip_force_un != 0.0) {
    const double area = b.thickness * b.thickness;
    model.add_face_traction(1, {0, 0, -tip_force_un / area}, {b.length - 1e-9, -1, -1},
                            {b.length + 1e-9, b.thickness + 1, b.thickness + 1});
  }
  HexSolveOptions o;
  o.formulation = formulation;
  const HexSolution s = solve_static(model, o);
  EXPECT_LT(s.stats.relative_residual, 1e-8);
  return -displacement_at(model, s, {b.length, b.thickness / 2, b.thickness / 2}).z;
}

double second_moment(const BeamCase& b) {
  return std::pow(b.thickness, 4) / 12.0;
}

TEST(FemHex, CantileverTipLoadMatchesPL3Over3EI) {
  const BeamCase b;        // L/t = 10, ν = 0
  const double p = 100.0;  // µN
  const double beam = p * std::pow(b.length, 3) / (3.0 * b.youngs * second_moment(b));
  std::printf("cantilever, tip load P = %.0f uN, L = %.0f mm, t = %.0f mm: PL^3/3EI = %.5f mm\n", p,
              b.length, b.thickness, beam);
  double error = 0.0;
  for (int across : {1, 2, 4, 8}) {
    const double full = cantilever_tip(b, across, false, p, HexFormulation::kFullIntegration);
    const double incompatible =
        cantilever_tip(b, across, false, p, HexFormulation::kIncompatibleModes);
    error = incompatible / beam - 1.0;
    std::printf(
        "  %d across: incompatible modes %.5f mm (%+.2f%%), full integration %.5f mm "
        "(%+.2f%%)\n",
        across, incompatible, 100 * error, full, 100 * (full / beam - 1.0));
    // Full integration is too stiff (parasitic shear); the incompatible element is not.
    EXPECT_LT(full, incompatible) << across;
  }
  EXPECT_LT(std::fabs(error), 0.02) << "finest resolution";
}

TEST(FemHex, CantileverUnderSelfWeightMatchesEulerBernoulliWithin2Percent) {
  const BeamCase b;
  const double q = b.density * 9810.0 * b.thickness * b.thickness;  // µN/mm
  const double beam = q * std::pow(b.length, 4) / (8.0 * b.youngs * second_moment(b));
  std::printf("cantilever under self-weight, L = %.0f mm, t = %.0f mm: qL^4/8EI = %.5f mm\n",
              b.length, b.thickness, beam);
  double previous = 1e9, error = 0.0;
  for (int across : {1, 2, 4, 8}) {
    const double tip = cantilever_tip(b, across, true, 0.0, HexFormulation::kIncompatibleModes);
    const double full = cantilever_tip(b, across, true, 0.0, HexFormulation::kFullIntegration);
    error = tip / beam - 1.0;
    std::printf("  %d across (h = %.3f mm): %.5f mm (%+.2f%%); full integration %+.2f%%\n", across,
                b.thickness / across, tip, 100 * error, 100 * (full / beam - 1.0));
    // The full-integration baseline converges from below (too stiff), monotonically.
    EXPECT_GT(full / beam, previous < 1e9 ? previous : 0.0) << across;
    previous = full / beam;
  }
  // The converged 3D solution exceeds Euler–Bernoulli by the shear deformation
  // (Timoshenko: 4EI/(κGAL²) = 0.8% here); 2% is the bound.
  EXPECT_LT(std::fabs(error), 0.02) << "finest resolution";
  EXPECT_GT(error, 0.0) << "shear deformation adds to the bending deflection";
}

TEST(FemHex, NearIncompressibleBendingIsNotLocked) {
  // ν = 0.49: the plain trilinear element locks (volumetric + parasitic shear) and is far too
  // stiff; the incompatible-mode element stays close to beam theory and converges. (The clamped
  // root restrains the lateral expansion at ν → ½, so the 3D answer sits slightly below
  // Euler–Bernoulli.)
  BeamCase b;
  b.poisson = 0.49;
  const double q = b.density * 9810.0 * b.thickness * b.thickness;
  const double beam = q * std::pow(b.length, 4) / (8.0 * b.youngs * second_moment(b));
  double previous = 0.0;
  for (int across : {1, 2, 4}) {
    const double incompatible =
        cantilever_tip(b, across, true, 0.0, HexFormulation::kIncompatibleModes);
    const double full = cantilever_tip(b, across, true, 0.0, HexFormulation::kFullIntegration);
    std::printf(
        "nu = 0.49, %d across: incompatible modes %+.2f%%, full integration %+.2f%% vs "
        "qL^4/8EI\n",
        across, 100 * (incompatible / beam - 1), 100 * (full / beam - 1));
    EXPECT_GT(incompatible, previous) << across;
    previous = incompatible;
    if (across == 4) {
      EXPECT_LT(std::fabs(incompatible / beam - 1.0), 0.04);
      EXPECT_LT(full / beam, 0.85) << "the plain element should show locking here";
    }
  }
}

TEST(FemHex, UniaxialBarMatchesFLOverEAExactly) {
  // 10 × 2 × 3 mm bar of anisotropic cells, end force F on the +x face.
  const double f = 50.0, youngs = 2e5;
  const Vec3d size{10, 2, 3};
  for (double nu : {0.0, 0.3, 0.49}) {
    for (HexFormulation form :
         {HexFormulation::kIncompatibleModes, HexFormulation::kFullIntegration}) {
      FemHexModel model(make_box_hex_mesh({8, 3, 4}, {1.25, 2.0 / 3, 0.75}, {0, 0, 0}),
                        {ElasticMaterial{youngs, nu, 0.0}});
      if (nu == 0.0) {
        model.fix_nodes_in_box({-1e-9, -1, -1}, {1e-9, 9, 9});  // full clamp: no Poisson coupling
      } else {
        // Rollers on three symmetry planes: lateral contraction is free, the stress uniform.
        model.fix_nodes_in_box({-1e-9, -1, -1}, {1e-9, 9, 9}, kAxisX);
        model.fix_nodes_in_box({-1, -1e-9, -1}, {99, 1e-9, 9}, kAxisY);
        model.fix_nodes_in_box({-1, -1, -1e-9}, {99, 9, 1e-9}, kAxisZ);
      }
      const double area = model.add_face_traction(1, {f / (size.y * size.z), 0, 0},
                                                  {size.x - 1e-9, -1, -1}, {size.x + 1e-9, 9, 9});
      ASSERT_NEAR(area, size.y * size.z, 1e-12);
      const HexSolution s = solve_static(model, HexSolveOptions{form});
      const double expected = f * size.x / (youngs * size.y * size.z);
      const double sigma = f / (size.y * size.z);
      for (std::int64_t n = 0; n < model.mesh().node_count(); ++n) {
        const Vec3d p = model.mesh().node_position(n);
        const Vec3d u = s.displacements[static_cast<std::size_t>(n)];
        ASSERT_NEAR(u.x, expected * p.x / size.x, 1e-9 * expected) << "nu " << nu << " node " << n;
        ASSERT_NEAR(u.y, -nu * sigma / youngs * p.y, 1e-9 * expected) << "nu " << nu;
        ASSERT_NEAR(u.z, -nu * sigma / youngs * p.z, 1e-9 * expected) << "nu " << nu;
      }
    }
  }
}

/// u = A·x + b, a general affine field (uniform strain plus a rigid rotation and translation).
Vec3d affine_field(const Vec3d& p) {
  return {1e-3 * p.x + 4e-4 * p.y - 2e-4 * p.z + 0.01, -3e-4 * p.x + 2e-3 * p.y + 5e-4 * p.z - 0.02,
          6e-4 * p.x - 1e-4 * p.y - 1.5e-3 * p.z + 0.005};
}

TEST(FemHex, PatchTestReproducesUniformStrainExactly) {
  // An L-shaped body of anisotropic cells; boundary nodes prescribed by an affine
  // field, interior nodes free. Every node and every point inside must follow the field exactly.
  for (HexFormulation form :
       {HexFormulation::kFullIntegration, HexFormulation::kIncompatibleModes}) {
    HexMesh mesh = make_box_hex_mesh({6, 5, 4}, {0.8, 1.1, 0.6}, {-1, 2, 0.5});
    for (int k = 0; k < 4; ++k)
      for (int j = 3; j < 5; ++j)
        for (int i = 3; i < 6; ++i)
          mesh.active[static_cast<std::size_t>(mesh.cell_index(i, j, k))] = 0;
    FemHexModel model(mesh, {ElasticMaterial{3e4, 0.3, 1e-3}});
    // A node is interior when all 8 cells around it are active.
    int interior = 0;
    const Int3 nd = mesh.node_dims();
    for (std::int64_t n = 0; n < mesh.node_count(); ++n) {
      if (!model.node_used(n)) continue;
      const Int3 p = mesh.node_coordinates(n);
      bool inside =
          p.x > 0 && p.y > 0 && p.z > 0 && p.x < nd.x - 1 && p.y < nd.y - 1 && p.z < nd.z - 1;
      for (int c = 0; c < 8 && inside; ++c)
        inside =
            mesh.cell_active(p.x - 1 + (c & 1), p.y - 1 + ((c >> 1) & 1), p.z - 1 + ((c >> 2) & 1));
      if (inside) {
        ++interior;
      } else {
        model.fix_node(n, kAllAxes, affine_field(mesh.node_position(n)));
      }
    }
    ASSERT_GT(interior, 10);
    const HexSolution s = solve_static(model, HexSolveOptions{form});
    for (std::int64_t n = 0; n < mesh.node_count(); ++n) {
      if (!model.node_used(n)) continue;
      const Vec3d e = affine_field(mesh.node_position(n));
      const Vec3d u = s.displacements[static_cast<std::size_t>(n)];
      ASSERT_NEAR(u.x, e.x, 1e-12) << to_string(form) << " node " << n;
      ASSERT_NEAR(u.y, e.y, 1e-12) << to_string(form) << " node " << n;
      ASSERT_NEAR(u.z, e.z, 1e-12) << to_string(form) << " node " << n;
    }
    // Inside cells too: the incompatible modes must stay silent under uniform strain.
    for (const Vec3d p : {Vec3d{0.1, 3.3, 1.1}, Vec3d{1.7, 4.9, 2.2}, Vec3d{-0.6, 6.9, 2.6}}) {
      const Vec3d u = displacement_at(model, s, p), e = affine_field(p);
      EXPECT_NEAR(u.x, e.x, 1e-12) << to_string(form);
      EXPECT_NEAR(u.y, e.y, 1e-12) << to_string(form);
      EXPECT_NEAR(u.z, e.z, 1e-12) << to_string(form);
    }
  }
}

TEST(FemHex, ConjugateGradientMatchesLdlt) {
  BeamCase b;
  b.poisson = 0.3;
  FemHexModel model(make_box_hex_mesh({20, 4, 4}, {0.5, 0.5, 0.5}, {0, 0, 0}),
                    {ElasticMaterial{b.youngs, b.poisson, b.density}});
  model.fix_nodes_in_box({-1e-9, -1, -1}, {1e-9, 9, 9});
  model.set_gravity({0, -3000, -9810});
  HexSolveOptions direct, iterative;
  direct.solver = LinearSolver::kSimplicialLdlt;
  iterative.solver = LinearSolver::kConjugateGradient;
  iterative.cg_tolerance = 1e-12;
  const HexSolution a = solve_static(model, direct), c = solve_static(model, iterative);
  EXPECT_EQ(a.stats.solver_used, LinearSolver::kSimplicialLdlt);
  EXPECT_EQ(c.stats.solver_used, LinearSolver::kConjugateGradient);
  EXPECT_GT(c.stats.cg_iterations, 0);
  double worst = 0, scale = 0;
  for (std::size_t n = 0; n < a.displacements.size(); ++n) {
    worst = std::max(worst, length(a.displacements[n] - c.displacements[n]));
    scale = std::max(scale, length(a.displacements[n]));
  }
  EXPECT_GT(scale, 0.0);
  EXPECT_LT(worst, 1e-8 * scale);
}

TEST(FemHex, LatticeTwinCoversTheLatticeCells) {
  crms::BoxLatticeOptions o;
  o.size_mm = {6, 4, 2};
  o.spacing_mm = 1.0;
  o.min_corner_mm = {-1, 0, 0};
  crms::Lattice lattice = crms::build_box_lattice(o);
  const std::int64_t anchored = crms::fix_nodes_behind_plane(lattice, {0, 0, 0}, {1, 0, 0});
  lattice.set_alive(lattice.geometry().index(5, 3, 1), false);
  const LatticeHexMesh twin = hex_mesh_from_lattice(lattice);
  EXPECT_EQ(static_cast<std::int64_t>(twin.anchored_cells.size()), anchored);
  EXPECT_EQ(twin.mesh.active_count(), lattice.alive_count());
  for (std::int64_t n = 0; n < lattice.node_count(); ++n) {
    const Vec3d c = twin.mesh.cell_centre(n), r = lattice.geometry().rest_position(n);
    EXPECT_NEAR(c.x, r.x, 1e-12);
    EXPECT_NEAR(c.y, r.y, 1e-12);
    EXPECT_NEAR(c.z, r.z, 1e-12);
    EXPECT_EQ(twin.mesh.active[static_cast<std::size_t>(n)] != 0, lattice.alive(n));
  }
  // Anchoring the twin's anchored cells clamps the body at the wall x = 0.
  FemHexModel model(twin.mesh, {ElasticMaterial{1e4, 0.0, 1e-3}});
  for (std::int64_t c : twin.anchored_cells) model.fix_cell_nodes(c);
  model.set_gravity({0, 0, -9810});
  const HexSolution s = solve_static(model);
  EXPECT_NEAR(displacement_at(model, s, {0.0, 2.0, 1.0}).z, 0.0, 1e-15);
  EXPECT_LT(displacement_at(model, s, {5.0, 2.0, 1.0}).z, 0.0);
}

TEST(FemHexRobustness, RejectsBadInputNamingTheProblem) {
  const HexMesh mesh = make_box_hex_mesh({4, 2, 2}, {1, 1, 1}, {0, 0, 0});
  auto expect_error = [](auto&& make, const std::string& needle) {
    try {
      make();
      ADD_FAILURE() << "no error; expected one mentioning '" << needle << "'";
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << e.what();
    }
  };
  expect_error(
      [&] {
        FemHexModel m(mesh, {ElasticMaterial{1e4, 0.5, 1e-3}});
      },
      "materials[0].poisson_ratio");
  expect_error(
      [&] {
        FemHexModel m(mesh, {ElasticMaterial{-5, 0.2, 1e-3}});
      },
      "materials[0].youngs_modulus");
  expect_error([&] { FemHexModel m(mesh, {}); }, "at least one material");
  expect_error(
      [&] {
        HexMesh bad = mesh;
        bad.material[3] = 2;
        FemHexModel m(bad, {ElasticMaterial{}});
      },
      "uses material 2");
  expect_error(
      [&] {
        FemHexModel m(mesh, {ElasticMaterial{}});
        m.set_gravity({0, 0, -9810});
        solve_static(m);
      },
      "not anchored");
  expect_error(
      [&] {
        // Anchored along x only: still free to slide along y and z.
        FemHexModel m(mesh, {ElasticMaterial{}});
        m.fix_nodes_in_box({-1, -1, -1}, {0.5, 9, 9}, kAxisX);
        solve_static(m);
      },
      "not anchored");
  expect_error(
      [&] {
        FemHexModel m(mesh, {ElasticMaterial{}});
        m.fix_nodes_in_box({-1, -1, -1}, {9, 9, 9});
        solve_static(m);
      },
      "nothing to solve");
  expect_error(
      [&] {
        FemHexModel m(mesh, {ElasticMaterial{}});
        m.add_nodal_force(m.mesh().node_count() + 3, {0, 0, 1});
      },
      "belongs to no active cell");
  expect_error(
      [&] {
        FemHexModel m(mesh, {ElasticMaterial{}});
        m.fix_nodes_in_box({-1, -1, -1}, {0.5, 9, 9});
        const HexSolution s = solve_static(m);
        displacement_at(m, s, {50, 0, 0});
      },
      "lies in no active cell");
}

}  // namespace
}  // namespace tsf::reference
