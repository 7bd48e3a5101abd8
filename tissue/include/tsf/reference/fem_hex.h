// Linear-elastic hexahedral FEM on the voxel/lattice grid: the static reference the CRMS lattice
// is measured against (docs/accuracy-vs-time.md, docs/design.md "What accuracy costs in time").
//
//   HexMesh mesh = make_box_hex_mesh({40, 4, 4}, {0.5, 0.5, 0.5}, {0, 0, 0});
//   FemHexModel model(mesh, {ElasticMaterial{1e6, 0.0, 1e-3}});
//   model.fix_nodes_in_box({-1e-9, -1, -1}, {1e-9, 99, 99});   // clamp the x = 0 face
//   model.set_gravity({0, 0, -9810});
//   HexSolution s = solve_static(model);
//   Vec3d tip = displacement_at(model, s, {20, 1, 1});            // mm
//
// Small-strain linear elasticity, trilinear 8-node elements (hex_element.h: Taylor–Wilson
// incompatible modes by default, or plain full integration), one element per active cell.
// Loads: gravity (body force ρ·g, consistent nodal loads ρ·g·V/8 per corner), nodal forces and
// face tractions (consistent: traction·area/4 per face corner). Dirichlet conditions per node and
// axis with prescribed values (anchors are all three axes at 0). The free unknowns satisfy
//   K_ff u_f = f_f − K_fp u_p,
// assembled once into an Eigen sparse matrix (symmetric positive definite once the anchors remove
// the rigid motions) and solved by
//   * SimplicialLDLT (sparse Cholesky, AMD ordering): exact to round-off, no tolerance to tune,
//     and bending of slender beams is ill-conditioned (κ grows like (L/h)²·(L/t)²), which makes
//     iterative solvers slow. The default up to kDirectSolverMaxUnknowns unknowns.
//   * ConjugateGradient + IncompleteCholesky: O(n) memory for large meshes, at a tolerance.
// The accuracy report measures both on the same problems.
//
// Units: mm, g, s (force µN, stress Pa, density g/mm³, acceleration mm/s²).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "tsf/common/vec3.h"
#include "tsf/reference/hex_element.h"
#include "tsf/reference/hex_mesh.h"

namespace tsf::reference {

/// Which axes a Dirichlet condition holds (bit a = axis a).
enum AxisMask : unsigned { kAxisX = 1u, kAxisY = 2u, kAxisZ = 4u, kAllAxes = 7u };

class FemHexModel {
 public:
  /// Validates the mesh and every material (tsf::Error naming the field); every active cell's
  /// material index must address `materials`.
  FemHexModel(HexMesh mesh, std::vector<ElasticMaterial> materials);

  const HexMesh& mesh() const { return mesh_; }
  const std::vector<ElasticMaterial>& materials() const { return materials_; }
  /// True when some active cell has node n as a corner (other nodes carry no unknowns).
  bool node_used(std::int64_t n) const { return used_[static_cast<std::size_t>(n)] != 0; }

  // ---- loads ----
  void set_gravity(const Vec3d& gravity_mm_s2) { gravity_ = gravity_mm_s2; }
  const Vec3d& gravity() const { return gravity_; }
  /// Adds a point force (µN) at node n (must be used).
  void add_nodal_force(std::int64_t n, const Vec3d& force_un);
  /// Adds a traction (Pa, force per area) on every exposed face whose outward normal is face
  /// direction d (0..5 = −x,+x,−y,+y,−z,+z) and whose centre lies in the closed box [lo, hi];
  /// returns the loaded area, mm².
  double add_face_traction(int direction, const Vec3d& traction_pa, const Vec3d& lo,
                           const Vec3d& hi);
  const std::vector<Vec3d>& nodal_forces() const { return forces_; }

  // ---- Dirichlet conditions ----
  /// Holds the axes in `axes` of node n at `value` (mm).
  void fix_node(std::int64_t n, unsigned axes = kAllAxes, const Vec3d& value = {});
  /// Holds every used node inside the closed box [lo, hi]; returns how many.
  std::int64_t fix_nodes_in_box(const Vec3d& lo, const Vec3d& hi, unsigned axes = kAllAxes,
                                const Vec3d& value = {});
  /// Holds the 8 corners of an anchored cell at 0 (a rigid anchored voxel/lattice cell).
  void fix_cell_nodes(std::int64_t cell);
  unsigned fixed_axes(std::int64_t n) const { return fixed_[static_cast<std::size_t>(n)]; }
  const Vec3d& prescribed(std::int64_t n) const { return prescribed_[static_cast<std::size_t>(n)]; }

 private:
  HexMesh mesh_;
  std::vector<ElasticMaterial> materials_;
  std::vector<std::uint8_t> used_, fixed_;
  std::vector<Vec3d> forces_, prescribed_;
  Vec3d gravity_{0.0, 0.0, 0.0};
};

enum class LinearSolver { kAuto, kSimplicialLdlt, kConjugateGradient };
const char* to_string(LinearSolver solver);

/// kAuto uses SimplicialLDLT up to this many free unknowns, ConjugateGradient above.
constexpr std::int64_t kDirectSolverMaxUnknowns = 200000;

struct HexSolveOptions {
  HexFormulation formulation = HexFormulation::kIncompatibleModes;
  LinearSolver solver = LinearSolver::kAuto;
  double cg_tolerance = 1e-10;  ///< relative residual of the CG solve, (0, 1e-2]
  int cg_max_iterations = 0;    ///< 0 = 10 × unknowns
};

struct HexSolveStats {
  std::int64_t unknowns = 0;  ///< free degrees of freedom
  std::int64_t nonzeros = 0;  ///< of the assembled K_ff
  LinearSolver solver_used = LinearSolver::kSimplicialLdlt;
  int cg_iterations = 0;
  double relative_residual = 0;  ///< |K_ff u_f − rhs| / |rhs| of the returned solution
  double assemble_s = 0, factorize_s = 0, solve_s = 0, total_s = 0;
};

struct HexSolution {
  std::vector<Vec3d> displacements;  ///< #nodes, mm (0 at unused nodes)
  /// #cells × 9 bubble amplitudes (mm) of the incompatible modes (hex_element.h); empty for full
  /// integration.
  std::vector<double> internal_modes;
  HexFormulation formulation = HexFormulation::kIncompatibleModes;
  HexSolveStats stats;
};

/// Static equilibrium K u = f. Throws tsf::Error when the model has no unknowns, when an
/// element-connected part of the mesh has no fixed node (a free rigid motion), or when the
/// factorisation or the solve fails (singular or indefinite system, CG not converged), naming
/// the reason.
HexSolution solve_static(const FemHexModel& model, const HexSolveOptions& options = {});

/// The FEM displacement field (mm) at a point of an active cell: trilinear corner interpolation
/// plus the cell's incompatible-mode bubbles. A point on a face shared by cells uses the lowest
/// active one; a point outside every active cell throws tsf::Error.
Vec3d displacement_at(const FemHexModel& model, const HexSolution& solution, const Vec3d& point);

}  // namespace tsf::reference
