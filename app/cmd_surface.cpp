// `tsf surface`: a density volume -> its IMT surface as a PLY mesh.
//
//   tsf surface DENSITY.nrrd [--iso 0.5] [--merge-eps 0.1] [--no-optimise] [--smooth N]
//               -o MESH.ply [--stats] [--threads N]
//
// DENSITY.nrrd is read with tsf::import::read_tissue_volume (a PREFIX-density.nrrd brings its
// labels along). The mesh is in tissue space (mm, axis-aligned; the image direction is not
// applied), normals point out of the tissue, each vertex carries its tissue label.
#include <omp.h>

#include <nlohmann/json.hpp>

#include <cstdio>
#include <filesystem>
#include <string>

#include "commands.h"
#include "tsf/common/error.h"
#include "tsf/common/stopwatch.h"
#include "tsf/imt/extract_surface.h"
#include "tsf/imt/mesh_quality.h"
#include "tsf/imt/mesh_smoothing.h"
#include "tsf/imt/mesh_topology.h"
#include "tsf/imt/surface_ply.h"

#ifdef TSF_HAVE_IMPORT
#include "tsf/import/tissue_volume_io.h"
#endif

namespace tsf::app {

namespace {

struct SurfaceArgs {
  std::string input, output;
  float iso = 0.5f;
  float merge_eps = 0.1f;
  bool no_optimise = false;
  int smooth = 0;
  bool stats = false;
  int threads = 0;
};

#ifdef TSF_HAVE_IMPORT
std::string lower_extension(const std::filesystem::path& p) {
  std::string e = p.extension().string();
  for (char& c : e) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return e;
}
#endif

void run_surface(const SurfaceArgs& a) {
#ifndef TSF_HAVE_IMPORT
  (void)a;
  throw Error("'tsf surface' reads volumes through ITK: reconfigure with -DTSF_WITH_ITK=ON");
#else
  namespace fs = std::filesystem;
  require(lower_extension(a.output) == ".ply",
          "output '" + a.output + "' must end in .ply (use 'tsf export' for other formats)");
  if (a.threads > 0) omp_set_num_threads(a.threads);
  imt::SurfaceOptions options;
  options.iso = a.iso;
  options.snap_epsilon = a.no_optimise ? 0.0f : a.merge_eps;
  options.validate();
  imt::TaubinOptions smoothing;
  smoothing.iterations = a.smooth;
  smoothing.validate();

  Stopwatch clock;
  const VoxelVolume volume = import::read_tissue_volume(a.input);
  const double t_read = clock.seconds();

  clock.restart();
  imt::SurfaceBuildStats build;
  imt::SurfaceMesh mesh = imt::extract_surface(volume, options, &build);
  const double t_surface = clock.seconds();

  clock.restart();
  if (a.smooth > 0) imt::smooth_taubin(mesh, smoothing);
  const double t_smooth = clock.seconds();
  // Without optimisation, the raw marching output: every triangle with its own three vertices.
  if (a.no_optimise) mesh = imt::unweld(mesh);

  clock.restart();
  imt::write_surface_ply(a.output, mesh);
  const double t_write = clock.seconds();

  if (a.stats) {
    const imt::MeshTopology topo = imt::analyse_topology(mesh);
    const auto& g = volume.geometry();
    nlohmann::json j;
    j["input"] = a.input;
    j["output"] = a.output;
    j["dims"] = {g.dims.x, g.dims.y, g.dims.z};
    j["spacing_mm"] = {g.spacing.x, g.spacing.y, g.spacing.z};
    j["voxels"] = volume.voxel_count();
    j["iso"] = a.iso;
    j["merge_eps"] = options.snap_epsilon;
    j["optimised"] = !a.no_optimise;
    j["smooth_iterations"] = a.smooth;
    j["vertices"] = mesh.vertex_count();
    j["triangles"] = mesh.triangle_count();
    j["components"] = topo.components;
    j["closed_manifold"] = topo.closed_oriented_manifold();
    const imt::MeshQuality q = imt::measure_quality(mesh);
    j["quality"] = {{"zero_area_triangles", q.zero_area},
                    {"slivers_below_10_deg", q.slivers},
                    {"min_angle_deg", q.min_angle_deg},
                    {"mean_min_angle_deg", q.mean_min_angle_deg},
                    {"mean_edge_length_mm", q.mean_edge_length}};
    j["threads"] = build.threads;
    j["blocks"] = {{"total", build.blocks}, {"active", build.active_blocks}};
    j["times_s"] = {{"read", t_read},
                    {"surface", t_surface},
                    {"surface_ranges", build.ranges_s},
                    {"surface_count", build.mesh_s},
                    {"surface_write", build.assemble_s},
                    {"surface_normals", build.normals_s},
                    {"smooth", t_smooth},
                    {"write", t_write}};
    std::printf("%s\n", j.dump(2).c_str());
  }
#endif
}

}  // namespace

void add_surface_command(CLI::App& app) {
  auto args = std::make_shared<SurfaceArgs>();
  CLI::App* sub = app.add_subcommand(
      "surface",
      "Surface a density volume with Interactive Marching Tetrahedra and write a PLY mesh "
      "(tissue space, mm; normals out of the tissue; per-vertex tissue label)");
  sub->add_option("density", args->input,
                  "Density volume (NRRD/MHA; PREFIX-density.nrrd brings "
                  "PREFIX-labels.nrrd along)")
      ->required()
      ->check(CLI::ExistingFile);
  sub->add_option("-o,--output", args->output, "Output mesh (.ply), written atomically")
      ->required();
  sub->add_option("--iso", args->iso, "Density iso-level in (0, 1]")
      ->default_val(0.5f)
      ->check(CLI::Range(0.0f, 1.0f));
  sub->add_option("--merge-eps", args->merge_eps,
                  "Merge vertices within this fraction of a lattice edge of a lattice point "
                  "([0, 0.5); 0 = off)")
      ->default_val(0.1f)
      ->check(CLI::Range(0.0f, 0.4999f));
  sub->add_flag("--no-optimise", args->no_optimise,
                "Write the raw marching output: no vertex merging, no welding (each triangle has "
                "its own vertices and face normal)");
  sub->add_option("--smooth", args->smooth, "Taubin smoothing iterations (0 = none)")
      ->default_val(0)
      ->check(CLI::Range(0, 10000));
  sub->add_flag(
      "--stats", args->stats,
      "Print JSON statistics (vertices, triangles, components, triangle quality, times) to stdout");
  sub->add_option("--threads", args->threads, "Threads (0 = all cores)")
      ->default_val(0)
      ->check(CLI::Range(0, 1024));
  sub->callback([args] { run_surface(*args); });
}

}  // namespace tsf::app
