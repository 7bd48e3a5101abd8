// Full surfacing throughput: IMT (tissue/) against vtkFlyingEdges3D and vtkMarchingCubes on the
// same volume, in the same run, with the same thread count (OpenMP for IMT, vtkSMPTools for VTK).
//
//   bench_imt_vs_vtk [--threads N] [--reps R] [--sizes 128,256,512] [--no-cranium]
//
// Prints one table row per (volume, method): median wall time over R runs, voxels/s, triangles/s,
// output size and, for analytic volumes, vertex distance to the true surface (voxels); then the
// time ratios peer/IMT (> 1: IMT faster). IMT times include recomputing the brick density ranges,
// since VTK starts from raw data too.
#include <omp.h>
#include <vtkFloatArray.h>
#include <vtkFlyingEdges3D.h>
#include <vtkImageData.h>
#include <vtkMarchingCubes.h>
#include <vtkNew.h>
#include <vtkPointData.h>
#include <vtkPoints.h>
#include <vtkPolyData.h>
#include <vtkSMPTools.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "tsf/imt/extract_surface.h"
#include "tsf/volume/analytic_volumes.h"

#ifdef TSF_BENCH_HAVE_IMPORT
#include <itkImage.h>
#include <itkImageFileReader.h>

#include "tsf/import/itk_io_factories.h"
#endif

namespace {

using namespace tsf;
using Clock = std::chrono::steady_clock;

struct Dataset {
  std::string name;
  VoxelVolume volume;
  std::function<double(const Vec3d&)> sdf;  // empty when the surface is not analytic
  float iso = 0.5f;
};

struct Result {
  double ms = 0;
  std::size_t triangles = 0, vertices = 0;
  double err_mean = -1, err_max = -1;
};

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

template <typename Points>
void measure_error(const Dataset& d, const Points& points, std::size_t n, Result& r) {
  if (!d.sdf) return;
  const double h = d.volume.geometry().spacing.x;
  double sum = 0, mx = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const double e = std::fabs(d.sdf(points(i))) / h;
    sum += e;
    mx = std::max(mx, e);
  }
  r.err_mean = n ? sum / static_cast<double>(n) : 0;
  r.err_max = mx;
}

Result run_imt(Dataset& d, int reps, float eps, bool normals) {
  imt::SurfaceOptions o;
  o.iso = d.iso;
  o.snap_epsilon = eps;
  std::vector<double> t;
  imt::SurfaceMesh mesh;
  for (int r = 0; r < reps; ++r) {
    d.volume.density_data();  // marks the brick ranges stale: the build recomputes them
    const auto start = Clock::now();
    mesh = imt::extract_surface(d.volume, o, nullptr, normals);
    t.push_back(std::chrono::duration<double, std::milli>(Clock::now() - start).count());
  }
  d.volume.mark_all_modified();
  Result res{median(t), mesh.triangle_count(), mesh.vertex_count()};
  measure_error(
      d, [&](std::size_t i) { return to_double(mesh.positions[i]); }, mesh.vertex_count(), res);
  return res;
}

vtkNew<vtkImageData> to_vtk(const VoxelVolume& v) {
  vtkNew<vtkImageData> image;
  const auto& g = v.geometry();
  image->SetDimensions(g.dims.x, g.dims.y, g.dims.z);
  image->SetSpacing(g.spacing.x, g.spacing.y, g.spacing.z);
  image->SetOrigin(g.origin.x, g.origin.y, g.origin.z);
  vtkNew<vtkFloatArray> scalars;
  scalars->SetName("density");
  // Wrap, do not copy (save = 1: VTK never frees it).
  scalars->SetArray(const_cast<float*>(v.density_data().data()),
                    static_cast<vtkIdType>(v.voxel_count()), 1);
  image->GetPointData()->SetScalars(scalars);
  return image;
}

template <typename Filter>
Result run_vtk(const Dataset& d, vtkImageData* image, int reps, bool normals) {
  vtkNew<Filter> filter;
  filter->SetInputData(image);
  filter->SetValue(0, d.iso);
  filter->SetComputeNormals(normals);
  filter->SetComputeGradients(false);
  filter->SetComputeScalars(false);
  std::vector<double> t;
  for (int r = 0; r < reps; ++r) {
    filter->Modified();
    const auto start = Clock::now();
    filter->Update();
    t.push_back(std::chrono::duration<double, std::milli>(Clock::now() - start).count());
  }
  vtkPolyData* out = filter->GetOutput();
  Result res{median(t), static_cast<std::size_t>(out->GetNumberOfPolys()),
             static_cast<std::size_t>(out->GetNumberOfPoints())};
  vtkPoints* pts = out->GetPoints();
  if (pts)
    measure_error(
        d,
        [&](std::size_t i) {
          double p[3];
          pts->GetPoint(static_cast<vtkIdType>(i), p);
          return Vec3d{p[0], p[1], p[2]};
        },
        res.vertices, res);
  return res;
}

#ifdef TSF_BENCH_HAVE_IMPORT
/// The sample cranium (HU) as density: a linear ramp 0 -> 1 over threshold ± 100 HU.
std::optional<Dataset> cranium(double threshold_hu) {
  const std::string path =
      std::string(TSF_SOURCE_DIR) + "/data-samples/ct-head-cranium/cranium.nrrd";
  tsf::import::register_itk_io_factories();
  using Image = itk::Image<float, 3>;
  auto reader = itk::ImageFileReader<Image>::New();
  reader->SetFileName(path);
  try {
    reader->Update();
  } catch (const std::exception& e) {
    std::fprintf(stderr, "cranium not read (%s): %s\n", path.c_str(), e.what());
    return std::nullopt;
  }
  const Image* im = reader->GetOutput();
  const auto size = im->GetLargestPossibleRegion().GetSize();
  VolumeGeometry g;
  g.dims = {int(size[0]), int(size[1]), int(size[2])};
  g.spacing = {im->GetSpacing()[0], im->GetSpacing()[1], im->GetSpacing()[2]};
  g.origin = {im->GetOrigin()[0], im->GetOrigin()[1], im->GetOrigin()[2]};
  Dataset d{"cranium(" + std::to_string(int(threshold_hu)) + "HU)", VoxelVolume(g), {}, 0.5f};
  const float* hu = im->GetBufferPointer();
  auto& dens = d.volume.density_data();
  for (std::size_t i = 0; i < dens.size(); ++i)
    dens[i] =
        static_cast<float>(std::clamp(0.5 + (double(hu[i]) - threshold_hu) / 200.0, 0.0, 1.0));
  d.volume.mark_all_modified();
  return d;
}
#endif

}  // namespace

int main(int argc, char** argv) {
  int threads = 1, reps = 5;
  std::vector<int> sizes = {128, 256, 512};
  bool with_cranium = true;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--threads" && i + 1 < argc) {
      threads = std::atoi(argv[++i]);
    } else if (a == "--reps" && i + 1 < argc) {
      reps = std::atoi(argv[++i]);
    } else if (a == "--sizes" && i + 1 < argc) {
      sizes.clear();
      std::stringstream ss(argv[++i]);
      for (std::string s; std::getline(ss, s, ',');) sizes.push_back(std::atoi(s.c_str()));
    } else if (a == "--no-cranium") {
      with_cranium = false;
    } else {
      std::fprintf(stderr,
                   "usage: bench_imt_vs_vtk [--threads N] [--reps R] [--sizes 128,256,512] "
                   "[--no-cranium]\n");
      return a == "--help" || a == "-h" ? 0 : 2;
    }
  }
  if (threads < 1 || reps < 1) {
    std::fprintf(stderr, "--threads and --reps must be >= 1\n");
    return 2;
  }
  omp_set_num_threads(threads);
  vtkSMPTools::Initialize(threads);
  std::printf("threads: %d (OpenMP for IMT; vtkSMPTools backend %s with %d threads)\n", threads,
              vtkSMPTools::GetBackend(), vtkSMPTools::GetEstimatedNumberOfThreads());
  std::printf(
      "median of %d runs; err = |signed distance| of vertices to the analytic surface, "
      "voxels\n\n",
      reps);
  std::printf("%-18s %-26s %9s %9s %9s %10s %10s %8s %8s\n", "volume", "method", "ms", "Mvox/s",
              "Mtri/s", "triangles", "vertices", "errMean", "errMax");

  std::vector<std::function<std::optional<Dataset>()>> datasets;
  for (int n : sizes) {
    datasets.push_back([n]() -> std::optional<Dataset> {
      Dataset d{
          "blobs-" + std::to_string(n), make_blob_volume(cube_geometry({n, n, n}), 7), {}, 0.5f};
      return d;
    });
    datasets.push_back([n]() -> std::optional<Dataset> {
      const TorusField t{{0.5 * n + 0.21, 0.5 * n - 0.33, 0.5 * n + 0.12}, 0.3 * n, 0.12 * n};
      auto sdf = [t](const Vec3d& p) { return t.signed_distance(p); };
      return Dataset{"torus-" + std::to_string(n),
                     make_sdf_volume(cube_geometry({n, n, n}), sdf, 2.0), sdf, 0.5f};
    });
  }
#ifdef TSF_BENCH_HAVE_IMPORT
  if (with_cranium) datasets.push_back([] { return cranium(-300.0); });
#else
  if (with_cranium) std::printf("(cranium skipped: built without the import module)\n");
#endif

  struct Ratio {
    std::string name;
    double fe_geom, fe_norm, mc_geom;
  };
  std::vector<Ratio> ratios;
  for (auto& make : datasets) {
    std::optional<Dataset> d = make();
    if (!d) continue;
    const double mvox = static_cast<double>(d->volume.voxel_count()) * 1e-6;
    auto row = [&](const char* method, const Result& r) {
      std::printf("%-18s %-26s %9.2f %9.1f %9.2f %10zu %10zu", d->name.c_str(), method, r.ms,
                  mvox / r.ms * 1e3, static_cast<double>(r.triangles) * 1e-6 / r.ms * 1e3,
                  r.triangles, r.vertices);
      if (r.err_mean >= 0)
        std::printf(" %8.4f %8.4f\n", r.err_mean, r.err_max);
      else
        std::printf(" %8s %8s\n", "-", "-");
      std::fflush(stdout);
    };
    const Result imt_geom = run_imt(*d, reps, 0.0f, false);
    row("IMT geometry", imt_geom);
    const Result imt_full = run_imt(*d, reps, 0.1f, true);
    row("IMT merge0.1+normals", imt_full);
    vtkNew<vtkImageData> image = to_vtk(d->volume);
    const Result fe_geom = run_vtk<vtkFlyingEdges3D>(*d, image, reps, false);
    row("FlyingEdges3D geometry", fe_geom);
    const Result fe_norm = run_vtk<vtkFlyingEdges3D>(*d, image, reps, true);
    row("FlyingEdges3D +normals", fe_norm);
    const Result mc_geom = run_vtk<vtkMarchingCubes>(*d, image, reps, false);
    row("MarchingCubes geometry", mc_geom);
    ratios.push_back(
        {d->name, fe_geom.ms / imt_geom.ms, fe_norm.ms / imt_full.ms, mc_geom.ms / imt_geom.ms});
  }
  std::printf("\ntime ratios (peer / IMT; > 1 means IMT is faster)\n");
  std::printf("%-18s %22s %28s %22s\n", "volume", "FE geom / IMT geom", "FE+normals / IMT default",
              "MC geom / IMT geom");
  for (const Ratio& r : ratios)
    std::printf("%-18s %22.2f %28.2f %22.2f\n", r.name.c_str(), r.fe_geom, r.fe_norm, r.mc_geom);
  return 0;
}
