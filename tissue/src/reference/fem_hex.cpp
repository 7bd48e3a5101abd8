// Static linear-elastic FEM on the hexahedral grid (fem_hex.h).
#include "tsf/reference/fem_hex.h"

#include <Eigen/IterativeLinearSolvers>
#include <Eigen/SparseCholesky>
#include <Eigen/SparseCore>
#include <algorithm>
#include <cmath>
#include <numeric>
#include <sstream>

#include "tsf/common/error.h"
#include "tsf/common/stopwatch.h"

namespace tsf::reference {
namespace {

using SparseMatrix = Eigen::SparseMatrix<double>;  // int indices: up to 2^31 nonzeros

/// Union-find over nodes, to find the element-connected parts of the mesh.
class DisjointSets {
 public:
  explicit DisjointSets(std::int64_t n) : parent_(static_cast<std::size_t>(n)) {
    std::iota(parent_.begin(), parent_.end(), std::int64_t{0});
  }
  std::int64_t find(std::int64_t a) {
    while (parent_[static_cast<std::size_t>(a)] != a) {
      auto& p = parent_[static_cast<std::size_t>(a)];
      p = parent_[static_cast<std::size_t>(p)];
      a = p;
    }
    return a;
  }
  void unite(std::int64_t a, std::int64_t b) {
    a = find(a);
    b = find(b);
    if (a != b) parent_[static_cast<std::size_t>(std::max(a, b))] = std::min(a, b);
  }

 private:
  std::vector<std::int64_t> parent_;
};

}  // namespace

const char* to_string(LinearSolver solver) {
  switch (solver) {
    case LinearSolver::kAuto:
      return "auto";
    case LinearSolver::kSimplicialLdlt:
      return "simplicial-ldlt";
    case LinearSolver::kConjugateGradient:
      return "cg-incomplete-cholesky";
  }
  return "?";
}

FemHexModel::FemHexModel(HexMesh mesh, std::vector<ElasticMaterial> materials)
    : mesh_(std::move(mesh)), materials_(std::move(materials)) {
  mesh_.validate();
  if (materials_.empty()) throw Error("FEM model: at least one material is required");
  for (std::size_t i = 0; i < materials_.size(); ++i)
    validate_elastic_material(materials_[i], "materials[" + std::to_string(i) + "]");
  const auto nodes = static_cast<std::size_t>(mesh_.node_count());
  used_.assign(nodes, 0);
  fixed_.assign(nodes, 0);
  forces_.assign(nodes, Vec3d{});
  prescribed_.assign(nodes, Vec3d{});
  for (std::int64_t c = 0; c < mesh_.cell_count(); ++c) {
    if (!mesh_.active[static_cast<std::size_t>(c)]) continue;
    if (mesh_.material[static_cast<std::size_t>(c)] >= materials_.size()) {
      std::ostringstream s;
      s << "FEM model: cell " << c << " uses material "
        << int(mesh_.material[static_cast<std::size_t>(c)]) << " but only " << materials_.size()
        << " are given";
      throw Error(s.str());
    }
    const Int3 ijk = mesh_.cell_coordinates(c);
    for (int corner = 0; corner < 8; ++corner)
      used_[static_cast<std::size_t>(mesh_.corner_node(ijk, corner))] = 1;
  }
}

void FemHexModel::add_nodal_force(std::int64_t n, const Vec3d& force_un) {
  if (n < 0 || n >= mesh_.node_count() || !node_used(n))
    throw Error("FEM model: nodal force on node " + std::to_string(n) +
                ", which belongs to no active cell");
  if (!all_finite(force_un)) throw Error("FEM model: nodal force must be finite");
  forces_[static_cast<std::size_t>(n)] += force_un;
}

double FemHexModel::add_face_traction(int direction, const Vec3d& traction_pa, const Vec3d& lo,
                                      const Vec3d& hi) {
  if (direction < 0 || direction > 5) throw Error("FEM model: face direction must be 0..5");
  if (!all_finite(traction_pa)) throw Error("FEM model: traction must be finite");
  const int axis = direction / 2, sign = (direction & 1) ? 1 : -1;
  const int u = (axis + 1) % 3, v = (axis + 2) % 3;
  const double area = mesh_.spacing[u] * mesh_.spacing[v];
  double loaded = 0.0;
  for (std::int64_t c = 0; c < mesh_.cell_count(); ++c) {
    if (!mesh_.active[static_cast<std::size_t>(c)]) continue;
    const Int3 ijk = mesh_.cell_coordinates(c);
    Int3 nb = ijk;
    nb[axis] += sign;
    if (mesh_.cell_active(nb.x, nb.y, nb.z)) continue;  // interior face
    Vec3d centre = mesh_.cell_centre(c);
    centre[axis] += 0.5 * sign * mesh_.spacing[axis];
    bool inside = true;
    for (int a = 0; a < 3; ++a) inside = inside && centre[a] >= lo[a] && centre[a] <= hi[a];
    if (!inside) continue;
    // The face's 4 corners: those with offset (sign > 0 ? 1 : 0) along the axis.
    for (int corner = 0; corner < 8; ++corner) {
      const int bit = (corner >> axis) & 1;
      if (bit != (sign > 0 ? 1 : 0)) continue;
      forces_[static_cast<std::size_t>(mesh_.corner_node(ijk, corner))] +=
          traction_pa * (0.25 * area);
    }
    loaded += area;
  }
  return loaded;
}

void FemHexModel::fix_node(std::int64_t n, unsigned axes, const Vec3d& value) {
  if (n < 0 || n >= mesh_.node_count()) throw Error("FEM model: node index out of range");
  if (!all_finite(value)) throw Error("FEM model: prescribed displacement must be finite");
  const auto i = static_cast<std::size_t>(n);
  fixed_[i] = static_cast<std::uint8_t>(fixed_[i] | (axes & kAllAxes));
  for (int a = 0; a < 3; ++a)
    if (axes & (1u << a)) prescribed_[i][a] = value[a];
}

std::int64_t FemHexModel::fix_nodes_in_box(const Vec3d& lo, const Vec3d& hi, unsigned axes,
                                           const Vec3d& value) {
  std::int64_t count = 0;
  for (std::int64_t n = 0; n < mesh_.node_count(); ++n) {
    if (!node_used(n)) continue;
    const Vec3d p = mesh_.node_position(n);
    if (p.x >= lo.x && p.x <= hi.x && p.y >= lo.y && p.y <= hi.y && p.z >= lo.z && p.z <= hi.z) {
      fix_node(n, axes, value);
      ++count;
    }
  }
  return count;
}

void FemHexModel::fix_cell_nodes(std::int64_t cell) {
  if (cell < 0 || cell >= mesh_.cell_count()) throw Error("FEM model: cell index out of range");
  const Int3 ijk = mesh_.cell_coordinates(cell);
  for (int corner = 0; corner < 8; ++corner) fix_node(mesh_.corner_node(ijk, corner));
}

HexSolution solve_static(const FemHexModel& model, const HexSolveOptions& options) {
  const Stopwatch total;
  Stopwatch watch;
  const HexMesh& mesh = model.mesh();
  const std::int64_t nodes = mesh.node_count();
  if (!(options.cg_tolerance > 0.0 && options.cg_tolerance <= 1e-2))
    throw Error("FEM solve: cg_tolerance must be in (0, 1e-2]");
  if (options.cg_max_iterations < 0) throw Error("FEM solve: cg_max_iterations must be >= 0");

  // Every element-connected part needs anchors on all three axes (else it floats freely).
  {
    DisjointSets parts(nodes);
    for (std::int64_t c = 0; c < mesh.cell_count(); ++c) {
      if (!mesh.active[static_cast<std::size_t>(c)]) continue;
      const Int3 ijk = mesh.cell_coordinates(c);
      const std::int64_t first = mesh.corner_node(ijk, 0);
      for (int corner = 1; corner < 8; ++corner) parts.unite(first, mesh.corner_node(ijk, corner));
    }
    std::vector<std::uint8_t> part_axes(static_cast<std::size_t>(nodes), 0);
    for (std::int64_t n = 0; n < nodes; ++n)
      if (model.node_used(n))
        part_axes[static_cast<std::size_t>(parts.find(n))] |=
            static_cast<std::uint8_t>(model.fixed_axes(n));
    for (std::int64_t n = 0; n < nodes; ++n)
      if (model.node_used(n) && part_axes[static_cast<std::size_t>(parts.find(n))] != kAllAxes) {
        std::ostringstream s;
        s << "FEM solve: the part of the mesh containing node " << n << " at ("
          << mesh.node_position(n).x << ", " << mesh.node_position(n).y << ", "
          << mesh.node_position(n).z
          << ") mm is not anchored along every axis, so it can move freely; fix nodes of it";
        throw Error(s.str());
      }
  }

  // Unknown numbering: free (node, axis) pairs of used nodes.
  std::vector<std::int64_t> dof(static_cast<std::size_t>(3 * nodes), -1);
  std::int64_t unknowns = 0;
  for (std::int64_t n = 0; n < nodes; ++n)
    if (model.node_used(n))
      for (int a = 0; a < 3; ++a)
        if (!(model.fixed_axes(n) & (1u << a)))
          dof[static_cast<std::size_t>(3 * n + a)] = unknowns++;
  if (unknowns == 0) throw Error("FEM solve: every node is fixed; nothing to solve");

  // Element matrices, one per material (all cells have the same size).
  std::vector<HexElementMatrices> element(model.materials().size());
  for (std::size_t m = 0; m < element.size(); ++m)
    element[m] = hex_element_matrices(mesh.spacing, model.materials()[m], options.formulation);

  // Sparsity: a free unknown couples to the free unknowns of the nodes it shares a cell with.
  // Count per column first (at most 27 nodes × 3), then insert into reserved columns.
  if (unknowns > (std::int64_t{1} << 30) / 81)
    throw Error("FEM solve: " + std::to_string(unknowns) +
                " unknowns exceed the solver's index range");
  Eigen::VectorXi per_column(unknowns);
  per_column.setZero();
  const Int3 nd = mesh.node_dims();
  for (std::int64_t n = 0; n < nodes; ++n) {
    if (!model.node_used(n)) continue;
    const Int3 p = mesh.node_coordinates(n);
    int coupled = 0;
    for (int dk = -1; dk <= 1; ++dk)
      for (int dj = -1; dj <= 1; ++dj)
        for (int di = -1; di <= 1; ++di) {
          const int i = p.x + di, j = p.y + dj, k = p.z + dk;
          if (i < 0 || j < 0 || k < 0 || i >= nd.x || j >= nd.y || k >= nd.z) continue;
          // shares a cell: some active cell contains both nodes
          bool shared = false;
          for (int ck = std::max(p.z, k) - 1; ck <= std::min(p.z, k) && !shared; ++ck)
            for (int cj = std::max(p.y, j) - 1; cj <= std::min(p.y, j) && !shared; ++cj)
              for (int ci = std::max(p.x, i) - 1; ci <= std::min(p.x, i) && !shared; ++ci)
                shared = mesh.cell_active(ci, cj, ck);
          if (shared) coupled += 3;
        }
    for (int a = 0; a < 3; ++a) {
      const std::int64_t d = dof[static_cast<std::size_t>(3 * n + a)];
      if (d >= 0) per_column[d] = coupled;
    }
  }
  SparseMatrix k(unknowns, unknowns);
  k.reserve(per_column);
  Eigen::VectorXd rhs = Eigen::VectorXd::Zero(unknowns);

  // Loads: nodal forces and gravity (ρ·g·V/8 per corner).
  for (std::int64_t n = 0; n < nodes; ++n)
    for (int a = 0; a < 3; ++a) {
      const std::int64_t d = dof[static_cast<std::size_t>(3 * n + a)];
      if (d >= 0) rhs[d] += model.nodal_forces()[static_cast<std::size_t>(n)][a];
    }
  const double cell_volume = mesh.spacing.x * mesh.spacing.y * mesh.spacing.z;
  std::int64_t dofs_e[24];
  for (std::int64_t c = 0; c < mesh.cell_count(); ++c) {
    if (!mesh.active[static_cast<std::size_t>(c)]) continue;
    const Int3 ijk = mesh.cell_coordinates(c);
    const std::size_t mat = mesh.material[static_cast<std::size_t>(c)];
    const HexStiffness& ke = element[mat].stiffness;
    const Vec3d body =
        model.gravity() * (model.materials()[mat].density_g_per_mm3 * cell_volume / 8.0);
    Eigen::Matrix<double, 24, 1> up;
    for (int corner = 0; corner < 8; ++corner) {
      const std::int64_t n = mesh.corner_node(ijk, corner);
      for (int a = 0; a < 3; ++a) {
        dofs_e[3 * corner + a] = dof[static_cast<std::size_t>(3 * n + a)];
        up[3 * corner + a] = (model.fixed_axes(n) & (1u << a)) ? model.prescribed(n)[a] : 0.0;
        if (dofs_e[3 * corner + a] >= 0) rhs[dofs_e[3 * corner + a]] += body[a];
      }
    }
    const Eigen::Matrix<double, 24, 1> kup = ke * up;  // moves prescribed values to the rhs
    for (int col = 0; col < 24; ++col) {
      const std::int64_t dc = dofs_e[col];
      if (dc < 0) continue;
      rhs[dc] -= kup[col];
      for (int row = 0; row < 24; ++row) {
        const std::int64_t dr = dofs_e[row];
        if (dr >= 0) k.coeffRef(dr, dc) += ke(row, col);
      }
    }
  }
  k.makeCompressed();
  HexSolveStats stats;
  stats.unknowns = unknowns;
  stats.nonzeros = k.nonZeros();
  stats.assemble_s = watch.seconds();

  LinearSolver solver = options.solver;
  if (solver == LinearSolver::kAuto)
    solver = unknowns <= kDirectSolverMaxUnknowns ? LinearSolver::kSimplicialLdlt
                                                  : LinearSolver::kConjugateGradient;
  stats.solver_used = solver;
  Eigen::VectorXd u;
  if (solver == LinearSolver::kSimplicialLdlt) {
    watch.restart();
    Eigen::SimplicialLDLT<SparseMatrix> ldlt;
    ldlt.compute(k);
    stats.factorize_s = watch.seconds();
    if (ldlt.info() != Eigen::Success)
      throw Error("FEM solve: the sparse LDLT factorisation failed (singular stiffness?)");
    const Eigen::VectorXd d = ldlt.vectorD();
    const double d_max = d.cwiseAbs().maxCoeff();
    if (!(d.minCoeff() > 1e-13 * d_max))
      throw Error(
          "FEM solve: the stiffness matrix is singular or indefinite (a free rigid motion: add "
          "anchors)");
    watch.restart();
    u = ldlt.solve(rhs);
    stats.solve_s = watch.seconds();
  } else {
    watch.restart();
    Eigen::ConjugateGradient<SparseMatrix, Eigen::Lower | Eigen::Upper,
                             Eigen::IncompleteCholesky<double, Eigen::Lower>>
        cg;
    cg.setTolerance(options.cg_tolerance);
    cg.setMaxIterations(options.cg_max_iterations > 0
                            ? options.cg_max_iterations
                            : static_cast<int>(std::min<std::int64_t>(10 * unknowns, 1 << 30)));
    cg.compute(k);
    stats.factorize_s = watch.seconds();
    if (cg.info() != Eigen::Success)
      throw Error("FEM solve: the incomplete Cholesky preconditioner failed");
    watch.restart();
    u = cg.solve(rhs);
    stats.solve_s = watch.seconds();
    stats.cg_iterations = static_cast<int>(cg.iterations());
    if (cg.info() != Eigen::Success) {
      std::ostringstream s;
      s << "FEM solve: conjugate gradients did not reach the tolerance " << options.cg_tolerance
        << " in " << cg.iterations() << " iterations (error " << cg.error() << ")";
      throw Error(s.str());
    }
  }
  const double rhs_norm = rhs.norm();
  stats.relative_residual = (k * u - rhs).norm() / (rhs_norm > 0.0 ? rhs_norm : 1.0);
  if (!u.allFinite()) throw Error("FEM solve: the solution is not finite");

  HexSolution out;
  out.formulation = options.formulation;
  out.displacements.assign(static_cast<std::size_t>(nodes), Vec3d{});
  for (std::int64_t n = 0; n < nodes; ++n) {
    if (!model.node_used(n)) continue;
    for (int a = 0; a < 3; ++a) {
      const std::int64_t d = dof[static_cast<std::size_t>(3 * n + a)];
      out.displacements[static_cast<std::size_t>(n)][a] = d >= 0 ? u[d] : model.prescribed(n)[a];
    }
  }
  if (options.formulation == HexFormulation::kIncompatibleModes) {
    out.internal_modes.assign(static_cast<std::size_t>(9 * mesh.cell_count()), 0.0);
    for (std::int64_t c = 0; c < mesh.cell_count(); ++c) {
      if (!mesh.active[static_cast<std::size_t>(c)]) continue;
      const Int3 ijk = mesh.cell_coordinates(c);
      Eigen::Matrix<double, 24, 1> ue;
      for (int corner = 0; corner < 8; ++corner)
        for (int a = 0; a < 3; ++a)
          ue[3 * corner + a] =
              out.displacements[static_cast<std::size_t>(mesh.corner_node(ijk, corner))][a];
      const Eigen::Matrix<double, 9, 1> alpha =
          element[mesh.material[static_cast<std::size_t>(c)]].internal_modes * ue;
      for (int i = 0; i < 9; ++i)
        out.internal_modes[static_cast<std::size_t>(9 * c + i)] = alpha[i];
    }
  }
  stats.total_s = total.seconds();
  out.stats = stats;
  return out;
}

Vec3d displacement_at(const FemHexModel& model, const HexSolution& solution, const Vec3d& point) {
  const HexMesh& mesh = model.mesh();
  if (solution.displacements.size() != static_cast<std::size_t>(mesh.node_count()))
    throw Error("FEM field: the solution does not belong to this model");
  constexpr double kEps = 1e-9;
  int lo[3], hi[3];
  Vec3d t;
  for (int a = 0; a < 3; ++a) {
    t[a] = (point[a] - mesh.origin[a]) / mesh.spacing[a];
    lo[a] = std::max(0, static_cast<int>(std::ceil(t[a] - kEps)) - 1);
    hi[a] = std::min(mesh.cells[a] - 1, static_cast<int>(std::floor(t[a] + kEps)));
  }
  for (int k = lo[2]; k <= hi[2]; ++k)
    for (int j = lo[1]; j <= hi[1]; ++j)
      for (int i = lo[0]; i <= hi[0]; ++i) {
        if (!mesh.cell_active(i, j, k)) continue;
        const Int3 cell{i, j, k};
        const Vec3d w{t.x - i, t.y - j, t.z - k};
        Vec3d u{};
        for (int corner = 0; corner < 8; ++corner)
          u += solution.displacements[static_cast<std::size_t>(mesh.corner_node(cell, corner))] *
               hex_shape(corner, w);
        if (!solution.internal_modes.empty()) {
          const std::size_t base = static_cast<std::size_t>(9 * mesh.cell_index(i, j, k));
          for (int axis = 0; axis < 3; ++axis) {
            const double bubble = hex_bubble(axis, w);
            for (int a = 0; a < 3; ++a)
              u[a] +=
                  bubble * solution.internal_modes[base + static_cast<std::size_t>(3 * axis + a)];
          }
        }
        return u;
      }
  std::ostringstream s;
  s << "FEM field: point (" << point.x << ", " << point.y << ", " << point.z
    << ") mm lies in no active cell";
  throw Error(s.str());
}

}  // namespace tsf::reference
