// Scenes shared by the knob studies (scenes.h).
#include "scenes.h"

#include "lattice_static.h"

#include <algorithm>
#include <chrono>
#include <cmath>

#include "tsf/common/error.h"

namespace tsf::accuracy {

double Cantilever::euler_bernoulli_tip() const {
  const double q = density * gravity * thickness_mm * thickness_mm;  // µN/mm
  const double inertia = std::pow(thickness_mm, 4) / 12.0;
  return q * std::pow(length_mm, 4) / (8.0 * youngs_pa * inertia);
}

crms::Lattice Cantilever::lattice() const {
  const double h = spacing();
  crms::BoxLatticeOptions o;
  o.size_mm = {length_mm + h, thickness_mm, thickness_mm};
  o.spacing_mm = h;
  o.min_corner_mm = {-h, 0, 0};
  o.density_g_per_mm3 = density;
  crms::Lattice l = crms::build_box_lattice(o);
  crms::fix_nodes_behind_plane(l, {0, 0, 0}, {1, 0, 0});
  return l;
}

crms::Material Cantilever::material(double damping_time_s) const {
  crms::Material m;
  m.youngs_modulus_pa = youngs_pa;
  m.viscosity_pa_s = youngs_pa * damping_time_s;
  m.density_g_per_mm3 = density;
  return m;
}

crms::Lattice Block::lattice() const {
  crms::BoxLatticeOptions o;
  o.size_mm = {width_mm, width_mm, height_mm + spacing_mm};
  o.spacing_mm = spacing_mm;
  o.min_corner_mm = {0, 0, -spacing_mm};
  crms::Lattice l = crms::build_box_lattice(o);
  crms::fix_nodes_behind_plane(l, {0, 0, 0}, {0, 0, 1});
  return l;
}

std::vector<std::int64_t> block_patch_nodes(const Block& block, const crms::Lattice& lattice) {
  std::vector<std::int64_t> nodes;
  const double top = block.height_mm - 0.5 * block.spacing_mm, c = 0.5 * block.width_mm;
  for (std::int64_t n = 0; n < lattice.node_count(); ++n) {
    const Vec3d p = lattice.geometry().rest_position(n);
    if (std::fabs(p.z - top) < 1e-6 && std::fabs(p.x - c) < 0.5 * block.patch_mm &&
        std::fabs(p.y - c) < 0.5 * block.patch_mm)
      nodes.push_back(n);
  }
  return nodes;
}

crms::SolverConfig crms_config(const crms::Material& material, crms::Integrator integrator,
                               crms::AngularForm form, crms::AngularReactions reactions,
                               const Vec3d& gravity) {
  crms::SolverConfig c;
  c.backend = crms::Backend::kCpu;
  c.integrator = integrator;
  c.angular_form = form;
  c.angular_reactions = reactions;
  c.materials = {material};
  c.gravity = gravity;
  c.stability.velocity_limit = 0;  // measure the physics, not the limiter
  c.implicit_tolerance = 1e-10;
  c.implicit_newton_iterations = 12;
  return c;
}

StaticSolve crms_static(crms::Lattice lattice, const crms::SolverConfig& config,
                        const std::vector<std::int64_t>& load_nodes,
                        const std::vector<Vec3f>& loads_un) {
  crms::SolverConfig c = config;
  c.backend = crms::Backend::kCpu;
  const auto start = std::chrono::steady_clock::now();
  const crms::Solver s(std::move(lattice), c);
  const LatticeStaticResult r = solve_lattice_static(s, load_nodes, loads_un);
  StaticSolve out;
  out.displacements = r.displacements;
  out.relative_residual = r.relative_residual;
  out.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return out;
}

double mean_lattice_uz(const crms::Lattice& lattice, const std::vector<Vec3d>& u,
                       const std::function<bool(const Vec3d&)>& select) {
  double sum = 0;
  int count = 0;
  for (std::int64_t n = 0; n < lattice.node_count(); ++n) {
    if (!lattice.alive(n) || lattice.fixed(n)) continue;
    if (!select(lattice.geometry().rest_position(n))) continue;
    sum += u[static_cast<std::size_t>(n)].z;
    ++count;
  }
  if (count == 0) throw Error("mean_lattice_uz: no node selected");
  return sum / count;
}

FemTwin solve_fem_twin(const crms::Lattice& lattice, const reference::ElasticMaterial& material,
                       const Vec3d& gravity,
                       const std::function<void(reference::FemHexModel&)>& add_loads,
                       const reference::HexSolveOptions& options) {
  reference::LatticeHexMesh twin = reference::hex_mesh_from_lattice(lattice);
  FemTwin out;
  out.model = std::make_unique<reference::FemHexModel>(std::move(twin.mesh), std::vector{material});
  for (std::int64_t c : twin.anchored_cells) out.model->fix_cell_nodes(c);
  out.model->set_gravity(gravity);
  if (add_loads) add_loads(*out.model);
  out.solution = reference::solve_static(*out.model, options);
  return out;
}

double median_seconds(int repeats, const std::function<void()>& work) {
  std::vector<double> t;
  for (int r = 0; r < std::max(1, repeats); ++r) {
    const auto start = std::chrono::steady_clock::now();
    work();
    t.push_back(std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
  }
  std::sort(t.begin(), t.end());
  return t[t.size() / 2];
}

double seconds_per_step(crms::Solver& solver, double dt, int steps, int repeats) {
  solver.step(2, dt);  // warm-up (first-touch allocations, thread start)
  return median_seconds(repeats, [&] { solver.step(steps, dt); }) / steps;
}

BlockPressureSolve solve_block_pressure(const Block& block) {
  BlockPressureSolve r;
  r.lattice = block.lattice();
  r.patch = block_patch_nodes(block, r.lattice);
  const double h = block.spacing_mm;
  const std::vector<Vec3f> forces(r.patch.size(),
                                  Vec3f{0, 0, static_cast<float>(-block.pressure_pa * h * h)});
  r.material.youngs_modulus_pa = block.youngs_pa;
  r.material.poisson_ratio = block.poisson_ratio;
  r.solve = crms_static(
      r.lattice,
      crms_config(r.material, crms::Integrator::kImplicitEuler, crms::AngularForm::kExact,
                  crms::AngularReactions::kSymmetric, {0, 0, 0}),
      r.patch, forces);
  return r;
}

}  // namespace tsf::accuracy
