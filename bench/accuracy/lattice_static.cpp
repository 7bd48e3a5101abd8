// Newton solver for the static equilibrium of a CRMS lattice (lattice_static.h).
#include "lattice_static.h"

#include <omp.h>

#include <Eigen/IterativeLinearSolvers>
#include <Eigen/SparseCholesky>
#include <Eigen/SparseLU>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <string>

#include "tsf/common/error.h"
#include "tsf/crms/dual.h"
#include "tsf/crms/effects.h"
#include "tsf/crms/node_force.h"
#include "tsf/crms/stencil.h"
#include "tsf/crms/volume_term.h"

namespace tsf::accuracy {
namespace {

using crms::Dual;
using crms::LatticeView;

/// Stencil accessor over double displacement arrays: every distinct node of the stencil carries
/// three derivative seeds on its displacement (velocities are zero: a static state).
template <int kSlots>
struct StaticDualStencil {
  using Scalar = Dual<3 * kSlots>;
  const LatticeView& lattice;
  const std::vector<double>* u_arrays;  // [3]
  const std::int64_t* slot_nodes;
  const int* slot_seed;

  Vec3<Scalar> u(int slot) const {
    const std::int64_t m = slot_nodes[slot];
    Vec3<Scalar> r{Scalar(u_arrays[0][m]), Scalar(u_arrays[1][m]), Scalar(u_arrays[2][m])};
    const int q = 3 * slot_seed[slot];
    r.x.d[q + 0] = 1.0;
    r.y.d[q + 1] = 1.0;
    r.z.d[q + 2] = 1.0;
    return r;
  }
  Vec3<Scalar> v(int) const { return {Scalar(0.0), Scalar(0.0), Scalar(0.0)}; }
  unsigned flags(int slot) const { return lattice.flags[slot_nodes[slot]]; }
  crms::MaterialBlend material(int slot) const {
    return crms::node_material(lattice, slot_nodes[slot]);
  }
};

/// The volumetric term (materials with ν > 0, volume_term.h) at displacements u: its forces
/// added to `residual` (free nodes) and its stiffness −∂f/∂u as triplets, per intact cube with
/// dual numbers seeded on the 8 corners' displacements.
void add_volume_term(const LatticeView& lat, const crms::VolumeParameters& vp,
                     const std::vector<double>* u, const std::vector<std::int64_t>& free_index,
                     Eigen::VectorXd& residual, std::vector<Eigen::Triplet<double>>& triplets) {
  using D = Dual<24>;
  for (std::int64_t c = 0; c < lat.count; ++c) {
    const std::int64_t rem = c % lat.stride_z;
    const int i = static_cast<int>(rem % lat.stride_y), j = static_cast<int>(rem / lat.stride_y);
    const int k = static_cast<int>(c / lat.stride_z);
    if (!crms::cube_intact(lat, i, j, k)) continue;
    float stiffness = 0.0f, damping = 0.0f;
    crms::cube_moduli(lat, vp, c, stiffness, damping);
    if (!(stiffness > 0.0f)) continue;
    std::int64_t corner[8];
    Vec3<D> cu[8];
    for (int q = 0; q < 8; ++q) {
      corner[q] = crms::cube_corner(lat, c, q);
      for (int a = 0; a < 3; ++a) {
        cu[q][a] = D(u[a][static_cast<std::size_t>(corner[q])]);
        cu[q][a].d[3 * q + a] = 1.0;
      }
    }
    const crms::CubeShape<D> shape = crms::cube_shape(cu, lat.rest_length);
    const D pressure = crms::volume_pressure(shape.strain, D(0.0), stiffness, 0.0f);
    for (int q = 0; q < 8; ++q) {
      const std::int64_t row = free_index[static_cast<std::size_t>(corner[q])];
      if (row < 0) continue;
      const Vec3<D> f = shape.gradient(q) * pressure;
      for (int a = 0; a < 3; ++a) residual(3 * row + a) += f[a].v;
      for (int r = 0; r < 8; ++r) {
        const std::int64_t col = free_index[static_cast<std::size_t>(corner[r])];
        if (col < 0) continue;
        for (int x = 0; x < 3; ++x)
          for (int y = 0; y < 3; ++y) {
            const double k_xy = -f[x].d[3 * r + y];
            if (k_xy != 0.0)
              triplets.emplace_back(static_cast<int>(3 * row + x), static_cast<int>(3 * col + y),
                                    k_xy);
          }
      }
    }
  }
}

template <unsigned F>
LatticeStaticResult solve(const crms::Solver& solver, const std::vector<Vec3d>& loads,
                          const LatticeStaticOptions& options) {
  constexpr bool kSymmetric = (F & crms::features::kSymmetricReactions) != 0;
  constexpr int kSlots = kSymmetric ? crms::kStencilSlots : crms::kGatherStencilSlots;
  using DualF = Dual<3 * kSlots>;
  const LatticeView lat = solver.lattice_view();
  const crms::MaterialPalette& palette = solver.palette();
  const Vec3d gravity = solver.config().gravity;
  const std::int64_t count = lat.count;
  const float rest[3] = {lat.rest_length[0], lat.rest_length[1], lat.rest_length[2]};

  std::vector<std::int64_t> free_index(static_cast<std::size_t>(count), -1), free_nodes;
  for (std::int64_t n = 0; n < count; ++n)
    if ((lat.flags[n] & (crms::kAliveBit | crms::kFixedBit)) == crms::kAliveBit) {
      free_index[static_cast<std::size_t>(n)] = static_cast<std::int64_t>(free_nodes.size());
      free_nodes.push_back(n);
    }
  const auto nf = static_cast<std::int64_t>(free_nodes.size());
  if (nf == 0) throw Error("lattice static solve: no free node");
  std::vector<double> u[3];
  for (auto& a : u) a.assign(static_cast<std::size_t>(count), 0.0);

  Eigen::VectorXd external(3 * nf);
  for (std::int64_t f = 0; f < nf; ++f) {
    const std::int64_t n = free_nodes[static_cast<std::size_t>(f)];
    const double mass = 1.0 / static_cast<double>(lat.inv_mass[n]);
    for (int a = 0; a < 3; ++a)
      external(3 * f + a) = loads[static_cast<std::size_t>(n)][a] + mass * gravity[a];
  }
  const double external_norm = std::max(external.norm(), 1e-300);
  const crms::VolumeParameters volume = crms::calibrate_volume(solver.config().materials);
  const bool volumetric = volume.lambda[0] > 0.0f;

  LatticeStaticResult out;
  const auto start = std::chrono::steady_clock::now();
  using Triplet = Eigen::Triplet<double>;
  Eigen::VectorXd residual(3 * nf);
  double previous_residual = std::numeric_limits<double>::infinity();
  for (int iteration = 0;; ++iteration) {
    std::vector<std::vector<Triplet>> triplets(static_cast<std::size_t>(omp_get_max_threads()));
#pragma omp parallel for schedule(dynamic, 64)
    for (std::int64_t f = 0; f < nf; ++f) {
      const std::int64_t n = free_nodes[static_cast<std::size_t>(f)];
      const std::int64_t rem = n % lat.stride_z;
      const int i = static_cast<int>(rem % lat.stride_y), j = static_cast<int>(rem / lat.stride_y);
      const int k = static_cast<int>(n / lat.stride_z);
      std::int64_t slot_nodes[kSlots], distinct[kSlots];
      int slot_seed[kSlots], distinct_count = 0;
      for (int slot = 0; slot < kSlots; ++slot) {
        const std::int64_t m = crms::stencil_node(lat, n, i, j, k, slot);
        const int q =
            static_cast<int>(std::find(distinct, distinct + distinct_count, m) - distinct);
        if (q == distinct_count) distinct[distinct_count++] = m;
        slot_nodes[slot] = m;
        slot_seed[slot] = q;
      }
      const StaticDualStencil<kSlots> st{lat, u, slot_nodes, slot_seed};
      const Vec3<DualF> fd = crms::spring_force<F>(st, rest, palette);
      auto& mine = triplets[static_cast<std::size_t>(omp_get_thread_num())];
      for (int q = 0; q < distinct_count; ++q) {
        const std::int64_t col = free_index[static_cast<std::size_t>(distinct[q])];
        if (col < 0) continue;
        for (int r = 0; r < 3; ++r)
          for (int c = 0; c < 3; ++c) {
            const double k_rc = -fd[r].d[3 * q + c];  // −∂f/∂u: the (positive) stiffness
            if (k_rc != 0.0)
              mine.emplace_back(static_cast<int>(3 * f + r), static_cast<int>(3 * col + c), k_rc);
          }
      }
      for (int a = 0; a < 3; ++a) residual(3 * f + a) = fd[a].v + external(3 * f + a);
    }
    if (volumetric) add_volume_term(lat, volume, u, free_index, residual, triplets[0]);
    out.relative_residual = residual.norm() / external_norm;
    if (!std::isfinite(out.relative_residual))
      throw Error("lattice static solve: the residual is not finite");
    if (out.relative_residual <= options.tolerance) break;
    // Round-off floor: the force function works in float (rest lengths, constants), so the
    // residual can stall near 1e-9 instead of reaching the tolerance; a stalled, tiny residual is
    // converged.
    if (iteration >= 2 && out.relative_residual < options.stall_tolerance &&
        out.relative_residual > 0.25 * previous_residual)
      break;
    previous_residual = out.relative_residual;
    if (iteration >= options.max_newton_iterations) {
      char text[64];
      std::snprintf(text, sizeof text, "%.3g", out.relative_residual);
      throw Error(std::string("lattice static solve: Newton did not converge (relative residual ") +
                  text + ")");
    }
    std::vector<Triplet> all;
    for (auto& t : triplets) all.insert(all.end(), t.begin(), t.end());
    Eigen::SparseMatrix<double> stiffness(static_cast<int>(3 * nf), static_cast<int>(3 * nf));
    stiffness.setFromTriplets(all.begin(), all.end());
    Eigen::VectorXd delta;
    if constexpr (kSymmetric) {
      // (K + Kᵀ)/2: K is symmetric up to rounding (forces derive from one potential).
      const Eigen::SparseMatrix<double> sym =
          0.5 * (stiffness + Eigen::SparseMatrix<double>(stiffness.transpose()));
      if (3 * nf <= options.direct_max_unknowns) {
        Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> ldlt(sym);
        if (ldlt.info() != Eigen::Success)
          throw Error("lattice static solve: LDLT failed (is the lattice anchored?)");
        delta = ldlt.solve(residual);
      } else {
        Eigen::ConjugateGradient<Eigen::SparseMatrix<double>, Eigen::Lower | Eigen::Upper,
                                 Eigen::IncompleteCholesky<double>>
            cg;
        cg.setTolerance(1e-12);
        cg.setMaxIterations(static_cast<int>(std::min<std::int64_t>(30 * nf, 1 << 30)));
        cg.compute(sym);
        delta = cg.solve(residual);
        if (cg.info() != Eigen::Success)
          throw Error("lattice static solve: conjugate gradients did not converge");
        out.iterative = true;
      }
    } else {
      Eigen::SparseLU<Eigen::SparseMatrix<double>> lu;
      lu.compute(stiffness);
      if (lu.info() != Eigen::Success)
        throw Error("lattice static solve: SparseLU failed (is the lattice anchored?)");
      delta = lu.solve(residual);
    }
    // f(u + δ) ≈ f(u) − K δ = −external  ⇒  K δ = f(u) + external = residual.
    for (std::int64_t f = 0; f < nf; ++f)
      for (int a = 0; a < 3; ++a)
        u[a][static_cast<std::size_t>(free_nodes[static_cast<std::size_t>(f)])] += delta(3 * f + a);
    ++out.newton_iterations;
  }
  out.displacements.resize(static_cast<std::size_t>(count));
  for (std::int64_t n = 0; n < count; ++n)
    out.displacements[static_cast<std::size_t>(n)] = {u[0][static_cast<std::size_t>(n)],
                                                      u[1][static_cast<std::size_t>(n)],
                                                      u[2][static_cast<std::size_t>(n)]};
  out.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return out;
}

}  // namespace

LatticeStaticResult solve_lattice_static(const crms::Solver& solver,
                                         const std::vector<std::int64_t>& load_nodes,
                                         const std::vector<Vec3f>& loads_un,
                                         const LatticeStaticOptions& options) {
  if (solver.on_cuda()) throw Error("lattice static solve: needs a CPU-backend solver");
  if (load_nodes.size() != loads_un.size())
    throw Error("lattice static solve: one load per load node expected");
  std::vector<Vec3d> loads(static_cast<std::size_t>(solver.lattice().node_count()));
  for (std::size_t i = 0; i < load_nodes.size(); ++i)
    loads[static_cast<std::size_t>(load_nodes[i])] += to_double(loads_un[i]);
  // External forces are handled here, not by the kernels' feature bit. Only the formulation
  // knobs are instantiated (each Dual<57> instantiation costs a minute of compile time).
  namespace ft = crms::features;
  const unsigned features = solver.features() & ~ft::kExternalForces;
  switch (features) {
    case 0:
      return solve<0>(solver, loads, options);
    case ft::kCosineAngular:
      return solve<ft::kCosineAngular>(solver, loads, options);
    case ft::kSymmetricReactions:
      return solve<ft::kSymmetricReactions>(solver, loads, options);
    case ft::kSymmetricReactions | ft::kCosineAngular:
      return solve<ft::kSymmetricReactions | ft::kCosineAngular>(solver, loads, options);
    default:
      throw Error("lattice static solve: heterogeneous lattices are not supported here");
  }
}

}  // namespace tsf::accuracy
