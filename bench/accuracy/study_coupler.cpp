// Knob study of the mesh coupler (docs/deform-cut.md "Coupler"): trilinear (8 corners) vs the
// thesis's local frame (origin + 3 edges, 4 corners), over the lattice spacing.
//
// Reference: an analytic deformation φ of the whole tissue — a bend of the body about the y axis
// (radius of curvature Rb, an isometric bend: x' = (Rb + z)·sin(x/Rb), z' = (Rb + z)·cos(x/Rb) − Rb
// in the body's frame), then a rigid rotation and a translation. Every lattice node is moved to
// φ(its rest position) (Solver::set_state), the product's coupler runs, and each render vertex is
// compared with φ(its rest position): the exact displaced surface point, so the error is the
// coupler's interpolation alone (it is the same for any solver state). Normals are compared with
// cof(∇φ)·n_rest, ∇φ by central differences of the analytic map.
#include <omp.h>

#include <algorithm>
#include <cmath>

#include "knob_study.h"
#include "scenes.h"
#include "tsf/interaction/tissue_model.h"
#include "tsf/volume/analytic_volumes.h"

namespace tsf::accuracy {
namespace {

constexpr double kPi = 3.14159265358979323846;

/// Bend (radius of curvature `bend_radius` about the y axis through `centre`), then rotate by
/// `angle` about `axis` (unit) around `centre`, then translate.
struct SmoothDeformation {
  Vec3d centre{0, 0, 0};
  double bend_radius = 50.0;  ///< mm
  Vec3d axis{0, 0, 1};
  double angle = 0.0;  ///< rad
  Vec3d translation{0, 0, 0};

  Vec3d operator()(const Vec3d& p) const {
    const Vec3d x = p - centre;
    const double a = x.x / bend_radius;
    const Vec3d b{(bend_radius + x.z) * std::sin(a), x.y,
                  (bend_radius + x.z) * std::cos(a) - bend_radius};
    // Rodrigues: b cosθ + (k × b) sinθ + k (k·b)(1 − cosθ).
    const double c = std::cos(angle), s = std::sin(angle);
    const Vec3d r = b * c + cross(axis, b) * s + axis * (dot(axis, b) * (1.0 - c));
    return centre + r + translation;
  }
  /// Deformed unit normal cof(∇φ)·n, ∇φ by central differences.
  Vec3d normal(const Vec3d& p, const Vec3d& n) const {
    const double e = 1e-4;
    const Vec3d cx = ((*this)(p + Vec3d{e, 0, 0}) - (*this)(p - Vec3d{e, 0, 0})) / (2 * e);
    const Vec3d cy = ((*this)(p + Vec3d{0, e, 0}) - (*this)(p - Vec3d{0, e, 0})) / (2 * e);
    const Vec3d cz = ((*this)(p + Vec3d{0, 0, e}) - (*this)(p - Vec3d{0, 0, e})) / (2 * e);
    const Vec3d m = cross(cy, cz) * n.x + cross(cz, cx) * n.y + cross(cx, cy) * n.z;
    return m / length(m);
  }
};

struct CouplerError {
  double mean_mm = 0, max_mm = 0, rms_mm = 0;
  double mean_normal_deg = 0;
  std::size_t vertices = 0;
};

CouplerError measure(const interaction::TissueModel& model, const SmoothDeformation& phi) {
  CouplerError e;
  const auto& rest = model.surface().positions();
  const auto& rest_n = model.surface().normals();
  const auto& p = model.coupler().positions();
  const auto& n = model.coupler().normals();
  std::size_t with_normal = 0;
  for (std::uint32_t s = 1; s < model.surface().vertex_slot_count(); ++s) {
    if (!model.surface().vertex_live(s)) continue;
    const Vec3d x = to_double(rest[s]);
    const double d = length(to_double(p[s]) - phi(x));
    e.mean_mm += d;
    e.rms_mm += d * d;
    e.max_mm = std::max(e.max_mm, d);
    ++e.vertices;
    if (length(rest_n[s]) < 0.5f) continue;  // IMT gives zero-area vertices no normal
    const double c =
        std::clamp(dot(to_double(n[s]), phi.normal(x, to_double(rest_n[s]))), -1.0, 1.0);
    e.mean_normal_deg += std::acos(c) * 180.0 / kPi;
    ++with_normal;
  }
  const double count = static_cast<double>(std::max<std::size_t>(1, e.vertices));
  e.mean_mm /= count;
  e.rms_mm = std::sqrt(e.rms_mm / count);
  e.mean_normal_deg /= static_cast<double>(std::max<std::size_t>(1, with_normal));
  return e;
}

const char* mode_name(coupler::CouplerMode mode) {
  return mode == coupler::CouplerMode::kTrilinear ? "trilinear" : "local frame";
}

StudyResult run(const RunOptions& options) {
  StudyResult out;
  const double voxel = options.quick ? 1.0 : 0.5;  // mm
  const double radius = 12.0, box = 30.0;          // mm
  const int n = static_cast<int>(std::lround(box / voxel));
  const std::vector<int> ks = options.quick ? std::vector<int>{2, 4} : std::vector<int>{1, 2, 4};
  const double c = 0.5 * box;
  SmoothDeformation phi;
  phi.centre = {c, c, c};
  phi.bend_radius = 40.0;
  phi.axis = Vec3d{1, 2, 2} / 3.0;
  phi.angle = 30.0 * kPi / 180.0;
  phi.translation = {1.0, -2.0, 0.5};
  const VoxelVolume volume = make_sdf_volume(
      cube_geometry({n, n, n}, voxel),
      [&](const Vec3d& p) {
        return length(p - Vec3d{c + 0.13, c - 0.07, c + 0.05}) - radius;
      },
      voxel);

  StudyTable t;
  t.caption = "**Sphere of tissue**, R = " + format_number(radius) + " mm in " +
              format_number(voxel) +
              " mm voxels (density ramp over ±1 voxel), bent about the y axis to a radius of "
              "curvature of " +
              format_number(phi.bend_radius) +
              " mm (surface strain up to ±R/Rb = " + format_percent(radius / phi.bend_radius, 2) +
              "), rotated 30° about (1, 2, 2)/3 and translated by (1, −2, 0.5) mm. Every lattice "
              "node sits exactly at φ(rest); error = |coupled vertex − φ(rest vertex)| over every "
              "render vertex, normal error against cof(∇φ)·n. Time: one full `couple()` on the "
              "CPU backend, per bound vertex.";
  t.columns = {"spacing",   "mode",         "vertices", "mean error",   "mean / voxel",
               "max error", "normal error", "couple()", "time / vertex"};
  PlotSeries s_tri{"trilinear (mean error)", {}}, s_loc{"local frame (mean error)", {}};
  struct Row {
    int k;
    coupler::CouplerMode mode;
    CouplerError e;
    double seconds, per_vertex;
  };
  std::vector<Row> rows;
  for (int k : ks) {
    for (coupler::CouplerMode mode :
         {coupler::CouplerMode::kTrilinear, coupler::CouplerMode::kLocalFrame}) {
      interaction::TissueModelOptions o;
      o.lattice.node_spacing_voxels = k;
      o.solver.backend = crms::Backend::kCpu;
      o.solver.gravity = {0, 0, 0};
      o.coupler_mode = mode;
      interaction::TissueModel model(VoxelVolume(volume), o);
      const crms::Lattice& lattice = model.solver().lattice();
      const crms::LatticeGeometry& g = lattice.geometry();
      std::vector<Vec3f> u(static_cast<std::size_t>(lattice.node_count())), v(u.size());
      for (std::int64_t i = 0; i < lattice.node_count(); ++i) {
        const Vec3d rest = g.rest_position(i);
        u[static_cast<std::size_t>(i)] = to_float(phi(rest) - rest);
      }
      model.solver().set_state(u, v);
      const double seconds = median_seconds(options.repeats, [&] { model.couple(); });
      const CouplerError e = measure(model, phi);
      const double per_vertex =
          seconds / static_cast<double>(std::max<std::size_t>(1, model.coupler().bound_count()));
      rows.push_back({k, mode, e, seconds, per_vertex});
      const double h = k * voxel;
      StudyRow r;
      r.cells = {format_number(h) + " mm",
                 mode_name(mode),
                 std::to_string(e.vertices),
                 format_number(e.mean_mm, 3) + " mm",
                 format_number(e.mean_mm / voxel, 3),
                 format_number(e.max_mm, 3) + " mm",
                 format_number(e.mean_normal_deg, 3) + "°",
                 format_seconds(seconds),
                 format_seconds(per_vertex)};
      r.errors = {{"mean_mm", e.mean_mm},
                  {"max_mm", e.max_mm},
                  {"rms_mm", e.rms_mm},
                  {"mean_normal_deg", e.mean_normal_deg}};
      r.times_s = {{"couple", seconds}, {"per_vertex", per_vertex}};
      t.rows.push_back(r);
      (mode == coupler::CouplerMode::kTrilinear ? s_tri : s_loc)
          .points.push_back({per_vertex, e.mean_mm, "h=" + format_number(h)});
    }
  }
  out.tables.push_back(t);
  out.plot.x_label = "coupling time per vertex (s)";
  out.plot.y_label = "mean vertex error vs the analytic deformation (mm)";
  out.plot.series = {s_tri, s_loc};

  // Rows alternate trilinear, local frame per spacing; finest spacing first.
  const StudyRow& fine_tri = t.rows[0];
  const StudyRow& fine_loc = t.rows[1];
  const StudyRow& coarse_tri = t.rows[t.rows.size() - 2];
  const StudyRow& coarse_loc = t.rows[t.rows.size() - 1];
  out.key_rows.push_back(
      {"coupler trilinear vs local frame, h = " + fine_tri.cells[0] + ", bent + rotated sphere",
       fine_tri.cells[3] + " vs " + fine_loc.cells[3] + " mean (max " + fine_tri.cells[5] + " vs " +
           fine_loc.cells[5] + ")",
       fine_tri.cells[8] + " vs " + fine_loc.cells[8] + " per vertex"});
  for (std::size_t m = 0; m < 2; ++m) {
    const Row& fine = rows[m];
    const Row& coarse = rows[rows.size() - 2 + m];
    out.checks.push_back(
        {std::string(mode_name(fine.mode)) +
             ": the finest spacing has a smaller mean error than the "
             "coarsest",
         fine.e.mean_mm < coarse.e.mean_mm,
         format_number(fine.e.mean_mm) + " mm at h = " + format_number(fine.k * voxel) + " vs " +
             format_number(coarse.e.mean_mm) + " mm at h = " + format_number(coarse.k * voxel)});
  }
  const double ratio_fine = rows[1].e.mean_mm / std::max(rows[0].e.mean_mm, 1e-30);
  const double ratio_coarse =
      rows.back().e.mean_mm / std::max(rows[rows.size() - 2].e.mean_mm, 1e-30);
  const double time_ratio = rows[1].per_vertex / rows[0].per_vertex;
  out.findings =
      "Both modes are exact for the rigid part of φ (rotation and translation are affine) and err "
      "only through the bend, so their error falls with the lattice spacing: trilinear " +
      coarse_tri.cells[3] + " at h = " + coarse_tri.cells[0] + " → " + fine_tri.cells[3] +
      " at h = " + fine_tri.cells[0] + "; local frame " + coarse_loc.cells[3] + " → " +
      fine_loc.cells[3] +
      ". The local frame is affine in each cube (its origin corner and three edges), so it cannot "
      "follow the bend inside a cube, where trilinear's bilinear terms partly do: its mean error "
      "is " +
      format_number(ratio_coarse, 2) + "× trilinear's mean error at the coarsest spacing and " +
      format_number(ratio_fine, 2) + "× at the finest; its normals are off by " +
      fine_loc.cells[6] + " against trilinear's " + fine_tri.cells[6] +
      " (the local frame's gradient is constant over the cube and jumps between cubes). In "
      "time the local frame costs " +
      format_number(time_ratio, 2) +
      "× the trilinear coupling per vertex here (corners are resolved once per cube either way in "
      "the two-pass coupler, so reading 4 corners instead of 8 saves only the interpolation). "
      "Trilinear stays the default: more accurate for little time, and continuous across cubes "
      "(a watertight surface).";
  return out;
}

}  // namespace

TSF_REGISTER_KNOB_STUDY(kCouplerStudy,
                        {"coupler-mode", "Coupler: trilinear vs local frame",
                         "coupler mode (trilinear / local frame) × lattice spacing",
                         "an analytic deformation (bend + rotation + translation): the exact "
                         "displaced surface point and normal",
                         "one full couple() on the CPU backend, per vertex (median)", 75, run});

}  // namespace tsf::accuracy
