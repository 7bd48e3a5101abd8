// Knob studies of the render surface (IMT, docs/imt.md): voxel resolution, and the mesh
// optimisation (vertex merging) and smoothing (Taubin). Reference: analytic surfaces — a sphere
// and a torus sampled into voxel volumes — whose signed distance, enclosed volume and area are
// known exactly.
#include <cmath>

#include "knob_study.h"
#include "scenes.h"
#include "tsf/imt/extract_surface.h"
#include "tsf/imt/mesh_quality.h"
#include "tsf/imt/mesh_smoothing.h"
#include "tsf/volume/analytic_volumes.h"

namespace tsf::accuracy {
namespace {

constexpr double kPi = 3.14159265358979323846;

struct SurfaceError {
  double mean_distance = 0, max_distance = 0;  ///< |signed distance| of vertices, mm
  double volume_error = 0;                     ///< enclosed / exact − 1
  double area_error = 0;                       ///< area / exact − 1
  imt::MeshQuality quality;
};

SurfaceError measure(const imt::SurfaceMesh& mesh, const std::function<double(const Vec3d&)>& sdf,
                     double exact_volume, double exact_area) {
  SurfaceError e;
  for (const Vec3f& p : mesh.positions) {
    const double d = std::fabs(sdf(to_double(p)));
    e.mean_distance += d;
    e.max_distance = std::max(e.max_distance, d);
  }
  e.mean_distance /= static_cast<double>(std::max<std::size_t>(1, mesh.vertex_count()));
  e.volume_error = imt::enclosed_volume(mesh) / exact_volume - 1.0;
  e.quality = imt::measure_quality(mesh);
  e.area_error = e.quality.area / exact_area - 1.0;
  return e;
}

StudyResult run_resolution(const RunOptions& options) {
  StudyResult out;
  const double radius = 10.0, box = 24.0;  // mm
  const std::vector<double> spacings =
      options.quick ? std::vector<double>{2.0, 1.0, 0.5} : std::vector<double>{2.0, 1.0, 0.5, 0.25};
  StudyTable t;
  t.caption =
      "**Sphere of radius 10 mm** in a 24 mm cube, sampled at voxel size h with the density "
      "ramping over ±1 voxel (partial volume, as in CT), surfaced at iso 0.5 with the default "
      "vertex merging (ε = 0.1). Exact: volume 4/3·πR³, area 4πR².";
  t.columns = {"voxel size",   "voxels",     "triangles", "mean |distance|", "max |distance|",
               "volume error", "area error", "min angle", "surface time"};
  PlotSeries s_dist{"mean |distance| / R", {}}, s_vol{"|volume error|", {}};
  const double exact_volume = 4.0 / 3.0 * kPi * radius * radius * radius;
  const double exact_area = 4.0 * kPi * radius * radius;
  for (double h : spacings) {
    const int n = static_cast<int>(std::lround(box / h));
    const SphereField sphere{{0.5 * box + 0.123 * h, 0.5 * box - 0.071 * h, 0.5 * box + 0.037 * h},
                             radius};
    auto sdf = [sphere](const Vec3d& p) { return sphere.signed_distance(p); };
    const VoxelVolume v = make_sdf_volume(cube_geometry({n, n, n}, h), sdf, h);
    imt::SurfaceMesh mesh;
    const double seconds = median_seconds(options.repeats, [&] { mesh = imt::extract_surface(v); });
    const SurfaceError e = measure(mesh, sdf, exact_volume, exact_area);
    StudyRow r;
    r.cells = {format_number(h) + " mm",
               std::to_string(v.geometry().voxel_count()),
               std::to_string(mesh.triangle_count()),
               format_number(e.mean_distance, 3) + " mm",
               format_number(e.max_distance, 3) + " mm",
               format_percent(e.volume_error, 2),
               format_percent(e.area_error, 2),
               format_number(e.quality.min_angle_deg, 3) + "°",
               format_seconds(seconds)};
    r.errors = {{"mean_distance_mm", e.mean_distance},
                {"max_distance_mm", e.max_distance},
                {"volume", e.volume_error},
                {"area", e.area_error}};
    r.times_s = {{"extract_surface", seconds}};
    t.rows.push_back(r);
    s_dist.points.push_back({seconds, e.mean_distance / radius, "h=" + format_number(h)});
    s_vol.points.push_back({seconds, std::fabs(e.volume_error), "h=" + format_number(h)});
  }
  out.tables.push_back(t);
  out.plot.x_label = "surface extraction time (s)";
  out.plot.y_label = "relative error";
  out.plot.series = {s_dist, s_vol};
  const StudyRow& coarse = t.rows.front();
  const StudyRow& fine = t.rows.back();
  out.key_rows.push_back({"IMT surface, sphere at h = " + fine.cells[0],
                          fine.cells[3] + " mean distance, volume " + fine.cells[5],
                          fine.cells[8]});
  out.checks.push_back({"the finest voxels give a smaller mean distance than the coarsest",
                        fine.errors[0].second < coarse.errors[0].second,
                        fine.cells[3] + " vs " + coarse.cells[3]});
  out.findings = "The surface converges to the sphere as the voxels shrink: mean vertex distance " +
                 coarse.cells[3] + " at h = " + coarse.cells[0] + ", " + fine.cells[3] +
                 " at h = " + fine.cells[0] + "; enclosed volume " + coarse.cells[5] + " → " +
                 fine.cells[5] +
                 ". Linear interpolation on a smooth density ramp is second order in h; the cost "
                 "grows as h⁻³ in voxels scanned and h⁻² in triangles made (" +
                 coarse.cells[8] + " → " + fine.cells[8] + ").";
  return out;
}

StudyResult run_optimisation(const RunOptions& options) {
  StudyResult out;
  const int n = options.quick ? 48 : 96;  // voxels of 1 mm
  struct Shape {
    std::string name;
    std::function<double(const Vec3d&)> sdf;
    double volume, area;
  };
  const double c = 0.5 * n - 0.5;
  const SphereField sphere{{c + 0.21, c - 0.13, c + 0.07}, 0.375 * n};
  const TorusField torus{{c + 0.21, c - 0.33, c + 0.12}, 0.3 * n, 0.12 * n};
  const std::vector<Shape> shapes = {
      {"sphere", [sphere](const Vec3d& p) { return sphere.signed_distance(p); },
       4.0 / 3.0 * kPi * std::pow(sphere.radius, 3), 4.0 * kPi * sphere.radius * sphere.radius},
      {"torus", [torus](const Vec3d& p) { return torus.signed_distance(p); },
       2.0 * kPi * kPi * torus.major * torus.minor * torus.minor,
       4.0 * kPi * kPi * torus.major * torus.minor}};
  struct Config {
    std::string name;
    float eps;
    int taubin;
  };
  const std::vector<Config> configs = {{"welded, no merging", 0.0f, 0},
                                       {"merge ε = 0.1 (default)", 0.1f, 0},
                                       {"merge ε = 0.2", 0.2f, 0},
                                       {"merge 0.1 + Taubin 5", 0.1f, 5},
                                       {"merge 0.1 + Taubin 20", 0.1f, 20}};
  StudyTable t;
  t.caption = "**Analytic shapes in a " + std::to_string(n) +
              "³ volume of 1 mm voxels** (sphere "
              "R = " +
              format_number(sphere.radius) + " mm; torus " + format_number(torus.major) + "/" +
              format_number(torus.minor) +
              " mm), density either a ramp over ±1 voxel (CT-like partial volume) or binary (a "
              "hard 0/1 step: a segmentation mask). Slivers: smallest angle < 10°.";
  t.columns = {"shape",        "density", "optimisation", "triangles", "mean |distance|",
               "volume error", "slivers", "min angle",    "time"};
  PlotSeries s_ramp{"ramp density (mean |distance|)", {}, false},
      s_binary{"binary mask (mean |distance|)", {}, false};
  for (const Shape& shape : shapes) {
    for (double ramp : {1.0, 0.0}) {
      const VoxelVolume v = make_sdf_volume(cube_geometry({n, n, n}), shape.sdf, ramp);
      for (const Config& cfg : configs) {
        imt::SurfaceOptions o;
        o.snap_epsilon = cfg.eps;
        imt::SurfaceMesh mesh;
        const double seconds = median_seconds(options.repeats, [&] {
          mesh = imt::extract_surface(v, o);
          if (cfg.taubin > 0) imt::smooth_taubin(mesh, {cfg.taubin, 0.5f, -0.53f});
        });
        const SurfaceError e = measure(mesh, shape.sdf, shape.volume, shape.area);
        StudyRow r;
        r.cells = {shape.name,
                   ramp > 0 ? "ramp" : "binary",
                   cfg.name,
                   std::to_string(mesh.triangle_count()),
                   format_number(e.mean_distance, 3) + " mm",
                   format_percent(e.volume_error, 2),
                   std::to_string(e.quality.slivers),
                   format_number(e.quality.min_angle_deg, 3) + "°",
                   format_seconds(seconds)};
        r.errors = {{"mean_distance_mm", e.mean_distance}, {"volume", e.volume_error}};
        r.times_s = {{"surface", seconds}};
        t.rows.push_back(r);
        if (shape.name == "sphere")
          (ramp > 0 ? s_ramp : s_binary).points.push_back({seconds, e.mean_distance, cfg.name});
      }
    }
  }
  out.tables.push_back(t);
  out.plot.x_label = "surface time, sphere (s)";
  out.plot.y_label = "mean |distance| to the sphere (mm)";
  out.plot.series = {s_ramp, s_binary};
  const std::size_t k = configs.size();
  // Rows: sphere ramp [0,k), sphere binary [k,2k), ...
  const StudyRow& ramp_weld = t.rows[0];
  const StudyRow& ramp_def = t.rows[1];
  const StudyRow& bin_def = t.rows[k + 1];
  const StudyRow& bin_t20 = t.rows[k + 4];
  out.key_rows.push_back({"IMT merging ε = 0.1 vs none (sphere, ramp): slivers",
                          ramp_def.cells[6] + " vs " + ramp_weld.cells[6],
                          ramp_def.cells[8] + " vs " + ramp_weld.cells[8]});
  out.key_rows.push_back({"Taubin 20 on a binary mask (sphere)",
                          bin_t20.cells[4] + " vs " + bin_def.cells[4] + " mean distance",
                          bin_t20.cells[8] + " vs " + bin_def.cells[8]});
  const StudyRow& ramp_t20 = t.rows[4];
  out.checks.push_back({"binary mask (sphere): 20 Taubin pairs reduce the mean distance",
                        bin_t20.errors[0].second < bin_def.errors[0].second,
                        bin_t20.cells[4] + " vs " + bin_def.cells[4]});
  out.checks.push_back({"ramp sphere: merging (ε = 0.1) leaves fewer slivers than none",
                        std::stoll(ramp_def.cells[6]) < std::stoll(ramp_weld.cells[6]),
                        ramp_def.cells[6] + " vs " + ramp_weld.cells[6]});
  out.findings =
      "Vertex merging (ε = 0.1) removes most slivers (" + ramp_weld.cells[6] + " → " +
      ramp_def.cells[6] + " on the ramp sphere) and " + ramp_weld.cells[3] + " → " +
      ramp_def.cells[3] + " triangles, at a distance cost of at most ε × edge (" +
      ramp_weld.cells[4] + " → " + ramp_def.cells[4] +
      "). Taubin smoothing removes the remaining slivers (minimum angle " + ramp_def.cells[7] +
      " → " + ramp_t20.cells[7] + " with 20 pairs) and halves the distance on a CT-like ramp (" +
      ramp_t20.cells[4] + "). On a binary mask the surface is a staircase (" + bin_def.cells[4] +
      " mean distance); 20 Taubin pairs bring it to " + bin_t20.cells[4] + " for " +
      bin_t20.cells[8] + " instead of " + bin_def.cells[8] +
      ", with the enclosed volume kept (Taubin's λ|μ pair does not shrink): a soft density ramp "
      "(the segmentation's partial-volume density) buys more accuracy than smoothing a mask.";
  return out;
}

}  // namespace

TSF_REGISTER_KNOB_STUDY(kImtResolutionStudy,
                        {"imt-resolution", "IMT surface: voxel resolution", "voxel size h",
                         "an analytic sphere (signed distance, volume, area)",
                         "full surface extraction (median)", 60, run_resolution});
TSF_REGISTER_KNOB_STUDY(kImtOptimisationStudy,
                        {"imt-optimisation", "IMT surface: vertex merging and smoothing",
                         "vertex merging ε and Taubin smoothing iterations",
                         "analytic sphere and torus (signed distance, volume)",
                         "surface extraction + smoothing (median)", 70, run_optimisation});

}  // namespace tsf::accuracy
