#include "tsf/crms/implicit_euler.h"

#include <omp.h>

#include <Eigen/Sparse>
#include <Eigen/SparseLU>
#include <algorithm>
#include <cmath>
#include <vector>

#include "tsf/common/error.h"
#include "tsf/crms/dual.h"
#include "tsf/crms/effects.h"
#include "tsf/crms/node_force.h"
#include "tsf/crms/node_update.h"
#include "tsf/crms/stencil.h"

namespace tsf::crms {
namespace {

using D6 = Dual<6>;

/// Stencil over double trial arrays; node `seed` carries derivative seeds: d[0..2] on its
/// displacement, d[3..5] on its velocity.
struct DualStencil {
  using Scalar = D6;
  const LatticeView& lattice;
  const std::vector<double>* u_arrays;  // [3]
  const std::vector<double>* v_arrays;  // [3]
  std::int64_t n;
  int i, j, k;
  std::int64_t seed;

  std::int64_t slot_index(int slot) const { return stencil_node(lattice, n, i, j, k, slot); }
  Vec3<D6> load(const std::vector<double>* a, int slot, int seed_offset) const {
    const std::int64_t m = slot_index(slot);
    Vec3<D6> r{D6(a[0][m]), D6(a[1][m]), D6(a[2][m])};
    if (m == seed) {
      r.x.d[seed_offset + 0] = 1.0;
      r.y.d[seed_offset + 1] = 1.0;
      r.z.d[seed_offset + 2] = 1.0;
    }
    return r;
  }
  // The accessor interface of node_force.h.
  Vec3<D6> u(int slot) const { return load(u_arrays, slot, 0); }
  Vec3<D6> v(int slot) const { return load(v_arrays, slot, 3); }
  unsigned flags(int slot) const { return lattice.flags[slot_index(slot)]; }
  int material(int slot) const { return lattice.material[slot_index(slot)]; }
};

struct Block {
  std::int64_t row, col;  // free-node indices
  double value[3][3];
};

template <unsigned F>
ImplicitStepStats implicit_step(const LatticeView& lat, const StateView& state,
                                const StepParameters& p, int max_iterations, double tolerance) {
  const std::int64_t count = lat.count;
  const double dt = static_cast<double>(p.dt);
  const int slots = (F & features::kSymmetricReactions) ? kStencilSlots : kGatherStencilSlots;
  const float rest[3] = {lat.rest_length[0], lat.rest_length[1], lat.rest_length[2]};

  std::vector<std::int64_t> free_index(static_cast<std::size_t>(count), -1);
  std::vector<std::int64_t> free_nodes;
  for (std::int64_t n = 0; n < count; ++n)
    if ((lat.flags[n] & (kAliveBit | kFixedBit)) == kAliveBit) {
      free_index[n] = static_cast<std::int64_t>(free_nodes.size());
      free_nodes.push_back(n);
    }
  const auto nf = static_cast<std::int64_t>(free_nodes.size());

  std::vector<double> u0[3], v0[3], u[3], v[3];
  for (int a = 0; a < 3; ++a) {
    u0[a].assign(state.u[a], state.u[a] + count);
    v0[a].assign(state.v[a], state.v[a] + count);
    u[a] = u0[a];
    v[a] = v0[a];
    for (std::int64_t n = 0; n < count; ++n)
      if (free_index[n] < 0) v[a][n] = 0.0;  // fixed and dead nodes do not move
  }

  ImplicitStepStats stats;
  Eigen::SparseLU<Eigen::SparseMatrix<double>, Eigen::COLAMDOrdering<int>> lu;
  Eigen::VectorXd g(3 * nf);
  bool pattern_analyzed = false;
  for (int iteration = 0;; ++iteration) {
    for (std::int64_t f = 0; f < nf; ++f) {
      const std::int64_t n = free_nodes[f];
      for (int a = 0; a < 3; ++a) u[a][n] = u0[a][n] + dt * v[a][n];
    }
    // Residual and Jacobian blocks, one free node per task.
    std::vector<std::vector<Block>> blocks(static_cast<std::size_t>(omp_get_max_threads()));
    double scale_sq = 0.0;
#pragma omp parallel for schedule(dynamic, 32) reduction(+ : scale_sq)
    for (std::int64_t f = 0; f < nf; ++f) {
      const std::int64_t n = free_nodes[f];
      const std::int64_t rem = n % (lat.stride_z);
      const int i = static_cast<int>(rem % lat.stride_y);
      const int j = static_cast<int>(rem / lat.stride_y);
      const int k = static_cast<int>(n / lat.stride_z);
      const double mass = 1.0 / static_cast<double>(lat.inv_mass[n]);
      auto& mine = blocks[static_cast<std::size_t>(omp_get_thread_num())];
      Vec3d force{0, 0, 0};
      std::int64_t seen[kStencilSlots];
      int seen_count = 0;
      for (int slot = 0; slot < slots; ++slot) {
        const std::int64_t m = stencil_node(lat, n, i, j, k, slot);
        if (std::find(seen, seen + seen_count, m) != seen + seen_count) continue;
        seen[seen_count++] = m;
        const DualStencil st{lat, u, v, n, i, j, k, m};
        const Vec3<D6> fd = spring_force<F>(st, rest, p.palette);
        if (slot == 0) force = {fd.x.v, fd.y.v, fd.z.v};
        const std::int64_t col = free_index[m];
        if (col < 0) continue;
        Block b{f, col, {}};
        for (int r = 0; r < 3; ++r)
          for (int c = 0; c < 3; ++c) {
            const double dfdu = fd[r].d[c], dfdv = fd[r].d[3 + c];
            b.value[r][c] = -dt * dfdv - dt * dt * dfdu + (m == n && r == c ? mass : 0.0);
          }
        mine.push_back(b);
      }
      Vec3d external{0, 0, 0};
      if constexpr ((F & features::kExternalForces) != 0)
        external = {lat.external_force[0][n], lat.external_force[1][n], lat.external_force[2][n]};
      for (int a = 0; a < 3; ++a) {
        const double momentum = mass * (v[a][n] - v0[a][n]);
        const double impulse =
            dt * (force[a] + external[a] + mass * static_cast<double>(p.gravity[a]));
        g(3 * f + a) = momentum - impulse;
        scale_sq += momentum * momentum + impulse * impulse;
      }
    }
    stats.relative_residual = g.norm() / (std::sqrt(scale_sq) + 1e-300);
    if (!std::isfinite(stats.relative_residual)) break;
    if (stats.relative_residual <= tolerance || nf == 0) {
      stats.converged = true;
      break;
    }
    if (iteration >= max_iterations) break;

    std::vector<Eigen::Triplet<double>> triplets;
    for (const auto& list : blocks)
      for (const Block& b : list)
        for (int r = 0; r < 3; ++r)
          for (int c = 0; c < 3; ++c)
            if (b.value[r][c] != 0.0)
              triplets.emplace_back(static_cast<int>(3 * b.row + r),
                                    static_cast<int>(3 * b.col + c), b.value[r][c]);
    Eigen::SparseMatrix<double> jacobian(3 * nf, 3 * nf);
    jacobian.setFromTriplets(triplets.begin(), triplets.end());
    if (!pattern_analyzed) {
      lu.analyzePattern(jacobian);
      pattern_analyzed = true;
    }
    lu.factorize(jacobian);
    if (lu.info() != Eigen::Success) break;  // singular: reported as not converged
    const Eigen::VectorXd delta = lu.solve(-g);
    for (std::int64_t f = 0; f < nf; ++f)
      for (int a = 0; a < 3; ++a) v[a][free_nodes[f]] += delta(3 * f + a);
    ++stats.newton_iterations;
  }

  // Stability controls, then positions from the (filtered) velocities; reject non-finite.
  std::vector<float> new_u[3], new_v[3];
  for (int a = 0; a < 3; ++a) {
    new_u[a].assign(state.u[a], state.u[a] + count);
    new_v[a].assign(static_cast<std::size_t>(count), 0.0f);
  }
  for (std::int64_t f = 0; f < nf; ++f) {
    const std::int64_t n = free_nodes[f];
    Vec3f vel{static_cast<float>(v[0][n]), static_cast<float>(v[1][n]),
              static_cast<float>(v[2][n])};
    vel = limit_velocity(vel, p.dt, p.kinetic_damping, p.velocity_limit);
    for (int a = 0; a < 3; ++a) {
      new_v[a][n] = vel[a];
      new_u[a][n] = static_cast<float>(u0[a][n] + dt * static_cast<double>(vel[a]));
    }
    if (!(crms_finite(vel) && std::isfinite(new_u[0][n]) && std::isfinite(new_u[1][n]) &&
          std::isfinite(new_u[2][n]))) {
      stats.first_non_finite_node = n;
      return stats;  // state untouched
    }
  }
  for (int a = 0; a < 3; ++a) {
    std::copy(new_u[a].begin(), new_u[a].end(), state.u[a]);
    std::copy(new_v[a].begin(), new_v[a].end(), state.v[a]);
  }
  return stats;
}

}  // namespace

ImplicitStepStats implicit_euler_step(const LatticeView& lattice, const StateView& state,
                                      const StepParameters& parameters, unsigned features,
                                      int max_newton_iterations, double tolerance) {
  require(max_newton_iterations >= 1, "implicit Euler needs at least one Newton iteration");
  return dispatch_features(features, [&](auto f) {
    return implicit_step<decltype(f)::value>(lattice, state, parameters, max_newton_iterations,
                                             tolerance);
  });
}

}  // namespace tsf::crms
