// The solver's API on every available backend: stepping, constraints, loads, topology edits,
// energies, the NaN guard's report and snapshots.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <thread>

#include "physics_assertions.h"
#include "tsf/common/error.h"

namespace tsf::crms {
namespace {

using test::available_backends;
using test::box;
using test::soft_material;

SolverConfig config_for(Backend backend) {
  SolverConfig c;
  c.backend = backend;
  c.materials = {soft_material()};
  return c;
}

TEST(CrmsSolver, FreeFallMatchesGravityExactly) {
  for (Backend backend : available_backends()) {
    SolverConfig c = config_for(backend);
    c.gravity = {0, 0, -9810};
    c.stability.velocity_limit = 0;
    Solver s(box({4, 4, 4}, 1), c);
    const double dt = 1e-4;
    s.step(100, dt);
    // Symplectic Euler: u = g·dt²·n(n+1)/2 for a rigid lattice (springs stay at rest).
    const double expected = -9810.0 * dt * dt * 100 * 101 / 2;
    for (const Vec3f& u : s.displacements()) EXPECT_NEAR(u.z, expected, 1e-4 * std::fabs(expected));
    const EnergyReport e = s.energy();
    EXPECT_NEAR(e.elastic_nj, 0.0, 1e-9);
    EXPECT_GT(e.kinetic_nj, 0.0);
    EXPECT_EQ(s.steps_done(), 100);
  }
}

TEST(CrmsSolver, AnchoredNodesStayAndConstraintsMoveNodes) {
  for (Backend backend : available_backends()) {
    SolverConfig c = config_for(backend);
    c.gravity = {0, 0, -9810};
    Lattice l = box({10, 4, 4}, 1);
    const std::int64_t anchored = fix_nodes_in_box(l, {-1, -1, -1}, {1, 5, 5});
    EXPECT_EQ(anchored, 16);
    Solver s(std::move(l), c);
    const double dt = 0.5 * s.stable_dt();
    s.step(200, dt);
    const auto u = s.displacements();
    for (std::int64_t n = 0; n < s.lattice().node_count(); ++n)
      if (s.lattice().fixed(n)) {
        EXPECT_EQ(u[n], (Vec3f{0, 0, 0}));
      }
    // Pull the free end up with a constraint: the constrained nodes sit exactly at the target.
    const auto tip = test::nodes_where(s.lattice(), [](Vec3d p) { return p.x > 9; });
    std::vector<Vec3d> targets;
    for (auto n : tip) targets.push_back(s.lattice().geometry().rest_position(n) + Vec3d{0, 0, 2});
    s.constrain_nodes(tip, targets);
    s.step(50, dt);
    const auto p = s.positions();
    for (std::size_t t = 0; t < tip.size(); ++t) EXPECT_NEAR(p[tip[t]].z, targets[t].z, 1e-5);
    s.release_nodes(tip);
    s.step(2000, dt);
    EXPECT_TRUE(test::assert_finite(s));
    EXPECT_LT(s.positions()[tip[0]].z, targets[0].z - 0.3);  // released: falls back
  }
}

// A tool contact's hold step: letting some nodes go and holding others in one edit of the backend
// (one upload and one wait on CUDA) is the two calls in that order, bit for bit.
TEST(CrmsSolver, ReleaseAndConstrainIsTheTwoCallsInOne) {
  for (Backend backend : available_backends()) {
    SolverConfig c = config_for(backend);
    c.gravity = {0, 0, -9810};
    auto make = [&] {
      Lattice l = box({8, 4, 4}, 1);
      fix_nodes_in_box(l, {-1, -1, -1}, {0.5, 5, 5});
      return Solver(std::move(l), c);
    };
    Solver two = make(), one = make();
    const double dt = 0.5 * two.stable_dt();
    const auto first = test::nodes_where(two.lattice(), [](Vec3d p) { return p.x > 6.5; });
    const auto second =
        test::nodes_where(two.lattice(), [](Vec3d p) { return p.x > 4.5 && p.x < 5.5; });
    auto lifted = [&](const std::vector<std::int64_t>& nodes, double dz) {
      std::vector<Vec3d> t;
      for (auto n : nodes) t.push_back(two.lattice().geometry().rest_position(n) + Vec3d{0, 0, dz});
      return t;
    };
    for (Solver* s : {&two, &one}) {
      s->constrain_nodes(first, lifted(first, 1.0));
      s->step(40, dt);
    }
    // Release the tip, hold a middle plane and one tip node again (in both lists: it ends up held).
    std::vector<std::int64_t> hold = second;
    hold.push_back(first.front());
    std::vector<Vec3d> targets = lifted(hold, -0.5);
    two.release_nodes(first);
    two.constrain_nodes(hold, targets);
    const std::uint64_t edits = one.edits();
    one.release_and_constrain(first, hold, targets);
    EXPECT_GT(one.edits(), edits);
    EXPECT_TRUE(one.lattice().fixed(first.front()));
    EXPECT_FALSE(one.lattice().fixed(first.back()));
    for (std::int64_t n = 0; n < one.lattice().node_count(); ++n)
      ASSERT_EQ(one.lattice().packed_flags(n), two.lattice().packed_flags(n)) << "node " << n;
    two.step(60, dt);
    one.step(60, dt);
    const auto a = two.displacements(), b = one.displacements();
    const auto va = two.velocities(), vb = one.velocities();
    for (std::size_t n = 0; n < a.size(); ++n) {
      ASSERT_EQ(a[n], b[n]) << one.backend_name() << " node " << n;
      ASSERT_EQ(va[n], vb[n]) << one.backend_name() << " node " << n;
    }
    const auto p = one.positions();
    for (std::size_t t = 0; t < hold.size(); ++t) EXPECT_NEAR(p[hold[t]].z, targets[t].z, 1e-5);
    EXPECT_LT(p[first.back()].z, lifted(first, 1.0).back().z - 0.05);  // let go: falls
    // Its arguments are checked as the two calls check theirs, before anything changes.
    const std::uint64_t before = one.edits();
    EXPECT_THROW(one.release_and_constrain({one.lattice().node_count()}, {}, {}), Error);
    EXPECT_THROW(one.release_and_constrain({}, {0}, {}), Error);
    EXPECT_THROW(one.release_and_constrain({}, {hold.front()}, {{std::nan(""), 0, 0}}), Error);
    EXPECT_EQ(one.edits(), before);
    EXPECT_TRUE(one.lattice().fixed(hold.front()));
  }
}

TEST(CrmsSolver, ExternalForceStretchesABarByFOverK) {
  // A 1D bar of 2 nodes, one fixed: a force F on the other stretches the spring to F/ks·L.
  for (Backend backend : available_backends()) {
    SolverConfig c = config_for(backend);
    c.materials = {soft_material(10e3, 2e-3)};
    c.stability.velocity_limit = 0;
    Lattice l = box({2, 1, 1}, 1);
    l.set_fixed(0, true);
    Solver s(std::move(l), c);
    const double ks = s.palette().entry[0].ks_linear[0];  // E·A = 10e3 · 1 mm² = 1e4 µN
    const float force = static_cast<float>(0.01 * ks);    // 1% strain
    s.set_external_forces({1}, {{force, 0, 0}});
    s.step(20000, 0.5 * s.stable_dt());
    EXPECT_NEAR(s.displacements()[1].x, 0.01, 1e-4);
  }
}

TEST(CrmsSolver, DeletedNodesStopAndTheirSpringsVanish) {
  for (Backend backend : available_backends()) {
    SolverConfig c = config_for(backend);
    c.gravity = {0, 0, -9810};
    Lattice l = box({6, 2, 2}, 1);
    fix_nodes_in_box(l, {-1, -1, -1}, {0.6, 3, 3});
    Solver s(std::move(l), c);
    const double dt = 0.5 * s.stable_dt();
    // Cut the bar through its middle by deleting the x = 2.5 layer: the far piece falls freely.
    const auto layer =
        test::nodes_where(s.lattice(), [](Vec3d p) { return std::fabs(p.x - 2.5) < 0.1; });
    s.delete_nodes(layer);
    const auto before = s.displacements();
    s.step(400, dt);
    const auto after = s.displacements();
    for (auto n : layer) EXPECT_EQ(after[n], before[n]);
    const auto far = test::nodes_where(s.lattice(), [](Vec3d p) { return p.x > 3; });
    const double t = 400 * dt;
    for (auto n : far) EXPECT_NEAR(after[n].z, -0.5 * 9810 * t * t, 0.02 * 0.5 * 9810 * t * t);
    // Breaking every spring of a node across x isolates the near side the same way.
    std::vector<SpringRef> springs;
    for (auto n :
         test::nodes_where(s.lattice(), [](Vec3d p) { return std::fabs(p.x - 0.5) < 0.1; }))
      springs.push_back({n, 1});
    s.break_springs(springs);
    EXPECT_FALSE(s.lattice().link(springs[0].node, 1));
    EXPECT_TRUE(test::assert_finite(s));
  }
}

TEST(CrmsSolver, NanGuardNamesTheFirstBadNodeAndHalts) {
  for (Backend backend : available_backends()) {
    SolverConfig c = config_for(backend);
    c.stability.velocity_limit = 0;
    Solver s(box({5, 5, 5}, 1), c);
    const double dt = 0.5 * s.stable_dt();
    s.step(3, dt);
    // A force that overflows float when divided by the node mass makes nodes 37 and 80 fail.
    const float huge = std::numeric_limits<float>::max();
    s.set_external_forces({80, 37}, {{huge, 0, 0}, {huge, 0, 0}});
    const StepReport r = s.step(10, dt);
    ASSERT_TRUE(r.instability.has_value()) << to_string(backend);
    EXPECT_EQ(r.instability->node, 37);
    EXPECT_EQ(r.instability->step, 3);
    EXPECT_EQ(r.instability->coordinates, (Int3{2, 2, 1}));
    EXPECT_EQ(s.steps_done(), 4);
    EXPECT_NE(r.instability->describe().find("node 37"), std::string::npos);
    // The state stayed finite and later steps do nothing.
    EXPECT_TRUE(std::isfinite(s.positions()[37].x));
    const auto frozen = s.displacements();
    EXPECT_EQ(s.step(5, dt).steps_run, 0);
    EXPECT_EQ(s.displacements()[12], frozen[12]);
    // After removing the cause and clearing, stepping resumes.
    s.clear_external_forces();
    s.clear_instability();
    EXPECT_EQ(s.step(5, dt).steps_run, 5);
    EXPECT_FALSE(s.instability().has_value());
  }
}

TEST(CrmsSolver, SnapshotsPublishPositionsWithAVersion) {
  for (Backend backend : available_backends()) {
    SolverConfig c = config_for(backend);
    c.gravity = {0, 0, -9810};
    Solver s(box({4, 3, 2}, 1), c);
    EXPECT_EQ(s.snapshots().version(), 0u);
    s.step(10, 1e-5);
    s.request_snapshot();
    // On CUDA the copy completes asynchronously: poll until published (bounded wait).
    for (int tries = 0; tries < 1000 && s.snapshots().version() == 0; ++tries) {
      s.poll_snapshot();
      std::this_thread::sleep_for(std::chrono::microseconds(100));
    }
    std::vector<float> xyz;
    std::int64_t step = -1;
    ASSERT_EQ(s.snapshots().copy_latest(xyz, &step), 1u) << to_string(backend);
    EXPECT_EQ(step, 10);
    const auto p = s.positions();
    ASSERT_EQ(xyz.size(), 3 * p.size());
    for (std::size_t n = 0; n < p.size(); ++n) EXPECT_FLOAT_EQ(xyz[3 * n + 2], p[n].z);
  }
}

TEST(CrmsSolver, InvalidConfigurationIsRejectedWithTheField) {
  SolverConfig c;
  c.materials = {soft_material()};
  c.materials[0].youngs_modulus_pa = -3;
  try {
    Solver s(box({2, 2, 2}, 1), c);
    FAIL() << "negative Young's modulus accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("materials[0].youngs_modulus"), std::string::npos)
        << e.what();
  }
  c.materials = {soft_material()};
  c.stability.kinetic_damping = std::nan("");
  EXPECT_THROW(Solver(box({2, 2, 2}, 1), c), Error);
  c.stability.kinetic_damping = 0;
  Solver s(box({2, 2, 2}, 1), c);
  EXPECT_THROW(s.step(1, 0.0), Error);
  EXPECT_THROW(s.step(1, std::numeric_limits<double>::infinity()), Error);
  EXPECT_THROW(s.constrain_nodes({99}, {{0, 0, 0}}), Error);
  if (!cuda_status().available) {
    c.backend = Backend::kCuda;
    try {
      Solver cuda(box({2, 2, 2}, 1), c);
      FAIL() << "CUDA backend created without a device";
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find(cuda_status().reason), std::string::npos);
    }
  }
}

TEST(CrmsSolver, SimulatedTimeAdvancesWithEveryIntegrator) {
  for (Integrator integrator :
       {Integrator::kExplicitEuler, Integrator::kSymplecticEuler, Integrator::kImplicitEuler}) {
    SolverConfig c;
    c.backend = Backend::kCpu;
    c.integrator = integrator;
    c.materials = {soft_material()};
    Solver s(box({3, 3, 3}, 1), c);
    const double dt = 0.5 * s.stable_dt();
    s.step(7, dt);
    s.step(3, dt);
    EXPECT_DOUBLE_EQ(s.time_s(), 10 * dt) << to_string(integrator);
    EXPECT_EQ(s.steps_done(), 10) << to_string(integrator);
  }
}

}  // namespace
}  // namespace tsf::crms
