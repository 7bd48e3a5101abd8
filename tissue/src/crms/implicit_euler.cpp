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
#include "tsf/crms/volume_term.h"

namespace tsf::crms {
namespace {

/// Stencil over double trial arrays where every distinct node of the stencil carries its own
/// six derivative seeds: node number q (in order of first appearance) has d[6q..6q+2] on its
/// displacement and d[6q+3..6q+5] on its velocity. One evaluation yields the node's whole
/// Jacobian row block (slots that fall outside the lattice alias the node itself, and so share
/// its seeds).
template <int kSlots>
struct DualStencil {
  using Scalar = Dual<6 * kSlots>;
  const LatticeView& lattice;
  const std::vector<double>* u_arrays;  // [3]
  const std::vector<double>* v_arrays;  // [3]
  const std::int64_t* slot_nodes;       // [kSlots] node read by each slot
  const int* slot_seed;                 // [kSlots] seed number of that node

  Vec3<Scalar> load(const std::vector<double>* a, int slot, int offset) const {
    const std::int64_t m = slot_nodes[slot];
    Vec3<Scalar> r{Scalar(a[0][m]), Scalar(a[1][m]), Scalar(a[2][m])};
    const int q = 6 * slot_seed[slot] + offset;
    r.x.d[q + 0] = 1.0;
    r.y.d[q + 1] = 1.0;
    r.z.d[q + 2] = 1.0;
    return r;
  }
  // The accessor interface of node_force.h.
  Vec3<Scalar> u(int slot) const { return load(u_arrays, slot, 0); }
  Vec3<Scalar> v(int slot) const { return load(v_arrays, slot, 3); }
  unsigned flags(int slot) const { return lattice.flags[slot_nodes[slot]]; }
  MaterialBlend material(int slot) const { return node_material(lattice, slot_nodes[slot]); }
};

struct Block {
  std::int64_t row, col;  // free-node indices
  double value[3][3];
};

/// The volumetric term at the trial state (u, v): each free node's force (µN, added to
/// `force`) and the Jacobian blocks −dt·∂f/∂v − dt²·∂f/∂u between free corners of each cube.
void add_volume_term(const LatticeView& lat, const VolumeParameters& vp,
                     const std::vector<double>* u, const std::vector<double>* v,
                     const std::vector<std::int64_t>& free_index, double dt,
                     std::vector<double>* force, std::vector<Block>& blocks) {
  using D = Dual<48>;  // seeds: corner q's u at 6q..6q+2, its v at 6q+3..6q+5
  const double v0 = cube_rest_volume(lat);
  for_each_volume_cube(lat, vp, [&](std::int64_t c, int, int, int, float stiffness, float damping) {
    std::int64_t corner[8];
    bool any_free = false;
    Vec3<D> cu[8], cv[8];
    for (int q = 0; q < 8; ++q) {
      corner[q] = cube_corner(lat, c, q);
      any_free = any_free || free_index[corner[q]] >= 0;
      for (int a = 0; a < 3; ++a) {
        cu[q][a] = D(u[a][corner[q]]);
        cu[q][a].d[6 * q + a] = 1.0;
        cv[q][a] = D(v[a][corner[q]]);
        cv[q][a].d[6 * q + 3 + a] = 1.0;
      }
    }
    if (!any_free) return;
    const CubeShape<D> shape = cube_shape(cu, lat.rest_length);
    D rate(0.0);
    for (int q = 0; q < 8; ++q) rate += dot(shape.gradient(q), cv[q]);
    rate = rate / D(v0);
    const D pressure = volume_pressure(shape.strain, rate, stiffness, damping);
    for (int q = 0; q < 8; ++q) {
      const std::int64_t row = free_index[corner[q]];
      if (row < 0) continue;
      const Vec3<D> f = shape.gradient(q) * pressure;
      for (int a = 0; a < 3; ++a) force[a][corner[q]] += f[a].v;
      for (int r = 0; r < 8; ++r) {
        const std::int64_t col = free_index[corner[r]];
        if (col < 0) continue;
        Block b{row, col, {}};
        for (int x = 0; x < 3; ++x)
          for (int y = 0; y < 3; ++y)
            b.value[x][y] = -dt * f[x].d[6 * r + 3 + y] - dt * dt * f[x].d[6 * r + y];
        blocks.push_back(b);
      }
    }
  });
}

template <unsigned F>
ImplicitStepStats implicit_step(const LatticeView& lat, const StateView& state,
                                const StepParameters& p, int max_iterations, double tolerance,
                                const VolumeParameters* volume) {
  constexpr int kSlots = (F & features::kSymmetricReactions) ? kStencilSlots : kGatherStencilSlots;
  using DualF = Dual<6 * kSlots>;
  const std::int64_t count = lat.count;
  const double dt = static_cast<double>(p.dt);
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

  std::vector<double> volume_force[3];

  ImplicitStepStats stats;
  Eigen::SparseLU<Eigen::SparseMatrix<double>, Eigen::COLAMDOrdering<int>> lu;
  Eigen::VectorXd g(3 * nf);
  bool pattern_analyzed = false;
  bool update_small = false;
  double initial_residual = 0.0;
  const double min_spacing = static_cast<double>(
      std::min(lat.rest_length[0], std::min(lat.rest_length[1], lat.rest_length[2])));
  for (int iteration = 0;; ++iteration) {
    for (std::int64_t f = 0; f < nf; ++f) {
      const std::int64_t n = free_nodes[f];
      for (int a = 0; a < 3; ++a) u[a][n] = u0[a][n] + dt * v[a][n];
    }
    // Residual and Jacobian blocks, one free node per task.
    std::vector<std::vector<Block>> blocks(static_cast<std::size_t>(omp_get_max_threads()));
    if (volume) {
      for (auto& a : volume_force) a.assign(static_cast<std::size_t>(count), 0.0);
      add_volume_term(lat, *volume, u, v, free_index, dt, volume_force, blocks[0]);
    }
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
      std::int64_t slot_nodes[kSlots];
      int slot_seed[kSlots];
      std::int64_t distinct[kSlots];
      int distinct_count = 0;
      for (int slot = 0; slot < kSlots; ++slot) {
        const std::int64_t m = stencil_node(lat, n, i, j, k, slot);
        int q = static_cast<int>(std::find(distinct, distinct + distinct_count, m) - distinct);
        if (q == distinct_count) distinct[distinct_count++] = m;
        slot_nodes[slot] = m;
        slot_seed[slot] = q;
      }
      const DualStencil<kSlots> st{lat, u, v, slot_nodes, slot_seed};
      const Vec3<DualF> fd = spring_force<F>(st, rest, p.palette);
      Vec3d force{fd.x.v, fd.y.v, fd.z.v};
      if (volume) force += Vec3d{volume_force[0][n], volume_force[1][n], volume_force[2][n]};
      for (int q = 0; q < distinct_count; ++q) {
        const std::int64_t m = distinct[q];
        const std::int64_t col = free_index[m];
        if (col < 0) continue;
        Block b{f, col, {}};
        for (int r = 0; r < 3; ++r)
          for (int c = 0; c < 3; ++c) {
            const double dfdu = fd[r].d[6 * q + c], dfdv = fd[r].d[6 * q + 3 + c];
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
    if (iteration == 0) initial_residual = g.norm();
    if (nf == 0 || stats.relative_residual <= tolerance ||
        g.norm() <= tolerance * initial_residual || update_small) {
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
    // The update moved no node by more than tolerance × spacing: converged to the precision the
    // float state can hold, even where the residual sits at its round-off floor.
    update_small = dt * delta.lpNorm<Eigen::Infinity>() <= tolerance * min_spacing;
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
                                      int max_newton_iterations, double tolerance,
                                      const VolumeParameters* volume) {
  require(max_newton_iterations >= 1, "implicit Euler needs at least one Newton iteration");
  return dispatch_features(features, [&](auto f) {
    return implicit_step<decltype(f)::value>(lattice, state, parameters, max_newton_iterations,
                                             tolerance, volume);
  });
}

}  // namespace tsf::crms
