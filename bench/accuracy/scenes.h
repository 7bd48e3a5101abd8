// Scenes shared by the knob studies: a cantilever under self-weight and a block under a pressure
// load, each built twice on the same cells — as a CRMS lattice and as its hexahedral FEM twin — and
// the helpers that solve them and compare them.
//
// Conventions (docs/accuracy-vs-time.md, "Conventions"): the body is the voxel body; anchored
// cells are a rigid layer behind the wall (lattice: the anchored nodes; FEM: every corner of the
// anchored cells). Lattice node values are compared with the FEM field at the same quantity of
// the body: the tip deflection (lattice: mean over the free-end node layer; FEM: the end face
// centre) and the displacement of a loaded surface.
#pragma once

#include <functional>
#include <memory>
#include <vector>

#include "tsf/common/vec3.h"
#include "tsf/crms/lattice_builders.h"
#include "tsf/crms/solver.h"
#include "tsf/reference/fem_hex.h"

namespace tsf::accuracy {

/// A square cantilever clamped at x = 0 (one anchored cell layer behind it), free length L,
/// side t, `across` lattice cells per side, under gravity −z.
struct Cantilever {
  double length_mm = 40.0;
  double thickness_mm = 4.0;
  int across = 4;
  double youngs_pa = 10e6;  ///< stiff enough that the sag stays linear (δ/L ≈ 0.6%)
  double density = 1e-3;    ///< g/mm³
  double gravity = 9810.0;  ///< mm/s²
  double spacing() const { return thickness_mm / across; }
  /// Euler–Bernoulli tip deflection qL⁴/8EI (mm, positive down).
  double euler_bernoulli_tip() const;
  crms::Lattice lattice() const;
  crms::Material material(double damping_time_s = 0.0) const;
};

/// The block study: W × W × H mm, bottom anchored (a layer behind z = 0), a pressure p on the
/// central patch of the top face (|x − W/2|, |y − W/2| ≤ patch/2), or on the whole top when
/// patch ≥ W.
struct Block {
  double width_mm = 16.0;
  double height_mm = 8.0;
  double patch_mm = 8.0;
  double spacing_mm = 1.0;
  double youngs_pa = 10e3;
  double pressure_pa = 100.0;  ///< 1% nominal strain under the patch: linear regime
  /// The lattice material's ν (0: the springs alone; > 0: with the volumetric term).
  double poisson_ratio = 0.0;
  crms::Lattice lattice() const;
};

/// CRMS static equilibrium under gravity and constant nodal loads (lattice_static.h: Newton
/// with the exact tangent stiffness of the product's force function).
struct StaticSolve {
  std::vector<Vec3d> displacements;  ///< #nodes, mm
  double seconds = 0;
  double relative_residual = 0;
};
StaticSolve crms_static(crms::Lattice lattice, const crms::SolverConfig& config,
                        const std::vector<std::int64_t>& load_nodes = {},
                        const std::vector<Vec3f>& loads_un = {});

/// A CRMS solver config for a study: CPU backend, one material, no velocity limit.
crms::SolverConfig crms_config(const crms::Material& material, crms::Integrator integrator,
                               crms::AngularForm form, crms::AngularReactions reactions,
                               const Vec3d& gravity);

/// Mean z displacement (mm) over alive unanchored lattice nodes with rest position satisfying
/// `select`.
double mean_lattice_uz(const crms::Lattice& lattice, const std::vector<Vec3d>& u,
                       const std::function<bool(const Vec3d&)>& select);

/// Block: nodes of the top layer under the patch and the per-node force of the pressure, µN.
std::vector<std::int64_t> block_patch_nodes(const Block& block, const crms::Lattice& lattice);

/// Block under its patch pressure, solved statically on the lattice (exact angles, symmetric
/// reactions, no gravity): the lattice, the loaded nodes, the material and the solution.
struct BlockPressureSolve {
  crms::Lattice lattice;
  std::vector<std::int64_t> patch;
  crms::Material material;
  StaticSolve solve;
};
BlockPressureSolve solve_block_pressure(const Block& block);

/// The FEM twin of a lattice (same cells, anchored cells rigid) with one material.
struct FemTwin {
  std::unique_ptr<reference::FemHexModel> model;
  reference::HexSolution solution;
};
FemTwin solve_fem_twin(const crms::Lattice& lattice, const reference::ElasticMaterial& material,
                       const Vec3d& gravity,
                       const std::function<void(reference::FemHexModel&)>& add_loads = {},
                       const reference::HexSolveOptions& options = {});

/// Median wall time (s) of `repeats` calls of `work` (each call timed alone).
double median_seconds(int repeats, const std::function<void()>& work);

/// Time per explicit step (s): median over `repeats` runs of `steps` steps of `solver` at dt.
double seconds_per_step(crms::Solver& solver, double dt, int steps, int repeats);

}  // namespace tsf::accuracy
