// Knob study: CRMS lattice spacing. Static cantilever deflection against the FEM on the same cells
// and against Euler–Bernoulli; block indentation against the FEM; and what a finer lattice costs
// per simulated second with the explicit integrator.
#include <cmath>

#include "knob_study.h"
#include "scenes.h"

namespace tsf::accuracy {
namespace {

using crms::AngularForm;
using crms::AngularReactions;
using crms::Integrator;

struct ExplicitCost {
  double stable_dt = 0, seconds_per_step = 0;
  double per_simulated_second() const { return seconds_per_step / (0.9 * stable_dt); }
};

/// Symplectic Euler at 0.9 × its stable step on this lattice: the time one step takes.
ExplicitCost explicit_cost(const crms::Lattice& lattice, const crms::Material& material,
                           const Vec3d& gravity, int repeats) {
  crms::SolverConfig c = crms_config(material, Integrator::kSymplecticEuler, AngularForm::kExact,
                                     AngularReactions::kSymmetric, gravity);
  crms::Solver s(lattice, c);
  ExplicitCost cost;
  cost.stable_dt = s.stable_dt();
  const int steps =
      std::max(4, static_cast<int>(40000 / std::max<std::int64_t>(1, lattice.alive_count())));
  cost.seconds_per_step = seconds_per_step(s, 0.9 * cost.stable_dt, steps, repeats);
  return cost;
}

StudyResult run(const RunOptions& options) {
  StudyResult out;
  PlotSeries s_beam_fem{"cantilever tip vs FEM", {}},
      s_beam_eb{"cantilever tip vs Euler–Bernoulli", {}},
      s_beam_field{"cantilever field vs FEM", {}}, s_block{"block indentation vs FEM", {}};

  // ---- cantilever ----
  StudyTable beam;
  beam.caption =
      "**Cantilever under self-weight**, L = 40 mm, t = 4 mm, E = 10 MPa (sag 0.6% of L: "
      "linear), ν = 0 (the lattice's own Poisson ratio), symmetric reactions, exact angles; static "
      "equilibrium of the lattice by implicit Euler with dt ≫ every period.";
  beam.columns = {"nodes across",
                  "spacing",
                  "nodes",
                  "lattice tip",
                  "FEM tip",
                  "tip vs FEM",
                  "tip vs Euler–Bernoulli",
                  "field vs FEM",
                  "stable dt",
                  "time / step",
                  "time / simulated s"};
  const std::vector<int> across_list =
      options.quick ? std::vector<int>{2, 4} : std::vector<int>{2, 4, 8};
  for (int across : across_list) {
    Cantilever b;
    b.across = across;
    const crms::Lattice lattice = b.lattice();
    const Vec3d gravity{0, 0, -b.gravity};
    const crms::Material material = b.material();
    const StaticSolve lat =
        crms_static(lattice, crms_config(material, Integrator::kImplicitEuler, AngularForm::kExact,
                                         AngularReactions::kSymmetric, gravity));
    const FemTwin fem = solve_fem_twin(lattice, {b.youngs_pa, 0.0, b.density}, gravity);
    const double h = b.spacing();
    const double tip_x = b.length_mm - 0.5 * h;
    const double lattice_tip = -mean_lattice_uz(
        lattice, lat.displacements, [&](const Vec3d& p) { return std::fabs(p.x - tip_x) < 1e-6; });
    const double fem_tip =
        -reference::displacement_at(*fem.model, fem.solution,
                                    {b.length_mm, 0.5 * b.thickness_mm, 0.5 * b.thickness_mm})
             .z;
    const double eb = b.euler_bernoulli_tip();
    // Field error: lattice node displacement vs the FEM field at the node's rest position.
    double diff2 = 0, ref2 = 0;
    for (std::int64_t n = 0; n < lattice.node_count(); ++n) {
      if (!lattice.alive(n) || lattice.fixed(n)) continue;
      const Vec3d uf =
          reference::displacement_at(*fem.model, fem.solution, lattice.geometry().rest_position(n));
      const Vec3d d = lat.displacements[static_cast<std::size_t>(n)] - uf;
      diff2 += dot(d, d);
      ref2 += dot(uf, uf);
    }
    const double field = std::sqrt(diff2 / ref2);
    const ExplicitCost cost = explicit_cost(lattice, material, gravity, options.repeats);
    StudyRow r;
    r.cells = {std::to_string(across),
               format_number(h) + " mm",
               std::to_string(lattice.alive_count()),
               format_number(lattice_tip, 4) + " mm",
               format_number(fem_tip, 4) + " mm",
               format_percent(lattice_tip / fem_tip - 1.0),
               format_percent(lattice_tip / eb - 1.0),
               format_percent(field),
               format_seconds(cost.stable_dt),
               format_seconds(cost.seconds_per_step),
               format_seconds(cost.per_simulated_second())};
    r.errors = {{"tip_vs_fem", lattice_tip / fem_tip - 1.0},
                {"tip_vs_euler_bernoulli", lattice_tip / eb - 1.0},
                {"field_vs_fem", field}};
    r.times_s = {{"step", cost.seconds_per_step},
                 {"per_simulated_second", cost.per_simulated_second()},
                 {"crms_static_solve", lat.seconds},
                 {"fem_solve", fem.solution.stats.total_s}};
    beam.rows.push_back(r);
    const std::string label = "h=" + format_number(h);
    s_beam_fem.points.push_back(
        {cost.per_simulated_second(), std::fabs(lattice_tip / fem_tip - 1.0), label});
    s_beam_eb.points.push_back(
        {cost.per_simulated_second(), std::fabs(lattice_tip / eb - 1.0), label});
    s_beam_field.points.push_back({cost.per_simulated_second(), field, label});
  }
  out.tables.push_back(beam);

  // ---- block indentation ----
  StudyTable block;
  block.caption =
      "**Block indentation**: 16 × 16 × 8 mm, bottom anchored, a pressure of 100 Pa on the central "
      "8 × 8 mm of the top (E = 10 kPa, ν = 0 for the FEM); depth = mean vertical displacement of "
      "the loaded surface.";
  block.columns = {"spacing",   "nodes",        "lattice depth",
                   "FEM depth", "depth vs FEM", "field vs FEM",
                   "stable dt", "time / step",  "time / simulated s"};
  const std::vector<double> spacings =
      std::vector<double>{2.0, 1.0};  // 0.5 mm (17k nodes) takes minutes: see the spacing trend
  for (double h : spacings) {
    Block blk;
    blk.spacing_mm = h;
    const BlockPressureSolve solved = solve_block_pressure(blk);
    const crms::Lattice& lattice = solved.lattice;
    const std::vector<std::int64_t>& patch = solved.patch;
    const crms::Material& material = solved.material;
    const StaticSolve& lat = solved.solve;
    const double c0 = 0.5 * (blk.width_mm - blk.patch_mm), c1 = 0.5 * (blk.width_mm + blk.patch_mm);
    const FemTwin fem = solve_fem_twin(
        lattice, {blk.youngs_pa, 0.0, 1e-3}, {0, 0, 0}, [&](reference::FemHexModel& m) {
          m.add_face_traction(5, {0, 0, -blk.pressure_pa}, {c0, c0, blk.height_mm - 1e-9},
                              {c1, c1, blk.height_mm + 1e-9});
        });
    double lattice_depth = 0, fem_depth = 0;
    for (std::int64_t n : patch) {
      lattice_depth -= lat.displacements[static_cast<std::size_t>(n)].z;
      const Vec3d p = lattice.geometry().rest_position(n);
      fem_depth -=
          reference::displacement_at(*fem.model, fem.solution, {p.x, p.y, blk.height_mm}).z;
    }
    lattice_depth /= static_cast<double>(patch.size());
    fem_depth /= static_cast<double>(patch.size());
    double diff2 = 0, ref2 = 0;
    for (std::int64_t n = 0; n < lattice.node_count(); ++n) {
      if (!lattice.alive(n) || lattice.fixed(n)) continue;
      const Vec3d uf =
          reference::displacement_at(*fem.model, fem.solution, lattice.geometry().rest_position(n));
      const Vec3d d = lat.displacements[static_cast<std::size_t>(n)] - uf;
      diff2 += dot(d, d);
      ref2 += dot(uf, uf);
    }
    const double field = std::sqrt(diff2 / ref2);
    const ExplicitCost cost = explicit_cost(lattice, material, {0, 0, 0}, options.repeats);
    StudyRow r;
    r.cells = {format_number(h) + " mm",
               std::to_string(lattice.alive_count()),
               format_number(lattice_depth, 4) + " mm",
               format_number(fem_depth, 4) + " mm",
               format_percent(lattice_depth / fem_depth - 1.0),
               format_percent(field),
               format_seconds(cost.stable_dt),
               format_seconds(cost.seconds_per_step),
               format_seconds(cost.per_simulated_second())};
    r.errors = {{"depth_vs_fem", lattice_depth / fem_depth - 1.0}, {"field_vs_fem", field}};
    r.times_s = {{"step", cost.seconds_per_step},
                 {"per_simulated_second", cost.per_simulated_second()},
                 {"crms_static_solve", lat.seconds},
                 {"fem_solve", fem.solution.stats.total_s}};
    block.rows.push_back(r);
    s_block.points.push_back({cost.per_simulated_second(),
                              std::fabs(lattice_depth / fem_depth - 1.0), "h=" + format_number(h)});
  }
  out.tables.push_back(block);

  out.plot.x_label = "explicit simulation cost: wall time per simulated second (s)";
  out.plot.y_label = "|relative error|";
  out.plot.series = {s_beam_fem, s_beam_eb, s_beam_field, s_block};

  const StudyRow& b0 = beam.rows.front();
  const StudyRow& b1 = beam.rows.back();
  const StudyRow& k0 = block.rows.front();
  const StudyRow& k1 = block.rows.back();
  out.key_rows.push_back({"CRMS spacing, cantilever tip vs FEM, " + b1.cells[0] + " across",
                          b1.cells[5], b1.cells[10] + " per simulated s"});
  out.key_rows.push_back({"CRMS spacing, block indentation vs FEM, h = " + k1.cells[0], k1.cells[4],
                          k1.cells[8] + " per simulated s"});
  out.findings =
      "The lattice converges to the FEM on the same cells as the spacing shrinks: the cantilever "
      "tip goes from " +
      b0.cells[5] + " (" + b0.cells[0] + " nodes across) to " + b1.cells[5] + " (" + b1.cells[0] +
      " across) against the FEM, " + b0.cells[6] + " → " + b1.cells[6] +
      " against Euler–Bernoulli, and the block indentation from " + k0.cells[4] + " to " +
      k1.cells[4] +
      ". The field error (node displacement vs the FEM field at the node) is larger "
      "than the tip error because the lattice's anchored node sits half a cell behind the wall "
      "(its clamp is effectively at the anchored node's centre) and a node lumps its cell at its "
      "centre; it falls with h like the tip error. The cost grows about as h⁻⁴ with the explicit "
      "integrator: h⁻³ nodes times a stable step ∝ h (from " +
      b0.cells[10] + " to " + b1.cells[10] + " per simulated second here).";
  return out;
}

}  // namespace

TSF_REGISTER_KNOB_STUDY(kCrmsSpacingStudy,
                        {"crms-spacing", "CRMS lattice spacing",
                         "lattice spacing h (nodes across the beam; block spacing)",
                         "the hexahedral FEM on the same cells (ν = 0) and Euler–Bernoulli "
                         "qL⁴/8EI",
                         "symplectic Euler at 0.9 × the stable step: wall time per step and per "
                         "simulated second (median)",
                         10, run});

}  // namespace tsf::accuracy
