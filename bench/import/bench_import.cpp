// tsf import vs plain ITK, in the same run, on the bundled samples.
//
//   GE head series (28 DICOM slices, gantry tilt, uneven spacing)
//     tsf:  import_volume(folder)  = DCMTK header scan + series checks + GDCM decode + resampling
//           onto an orthogonal grid (the series needs it)
//     ITK:  GDCMSeriesFileNames + ImageSeriesReader<float> (GDCMImageIO): sorts and stacks the
//           slices, ignores tilt and uneven spacing (a geometrically wrong volume, for timing)
//     ITK+resample: the same read followed by ResampleImageFilter (linear) onto tsf's output grid:
//           the like-for-like peer (same decode, same number of interpolated voxels)
//   cranium.nrrd (256×256×108 gzip NRRD)
//     tsf:  import_volume(file)    = header checks + ITK read + value statistics
//     ITK:  ImageFileReader<float>
//   Philips phantom series (28 slices, even spacing, no tilt; only when ../shared/data exists):
//     the like-for-like DICOM case, where tsf does no resampling
//
// Each case runs warm-up + N alternating repetitions (tsf, ITK, tsf, ITK, ...) so that load
// from other processes hits both alike; medians and the ratio of medians are printed as a
// markdown table. Also printed: the write step of `tsf import` (int16 gzip NRRD) for reference,
// and the resampling accuracy/time knob (output slice spacing) on an analytic field.
//
// Also printed: the cost of decoding compressed series in decoder processes (the GE series
// encoded by GDCM in RLE, JPEG lossless, JPEG-LS and JPEG 2000; decoders in processes vs inside
// tsf, alternated; skipped with --no-containment).
//
// Usage: bench_import [--repeats N] [--threads N] [--samples DIR] [--no-containment]
#include <itkGDCMImageIO.h>
#include <itkGDCMSeriesFileNames.h>
#include <itkImage.h>
#include <itkImageFileReader.h>
#include <itkImageSeriesReader.h>
#include <itkLinearInterpolateImageFunction.h>
#include <itkResampleImageFilter.h>
#include <omp.h>
#include <sys/resource.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include "support/gdcm_transcode.h"
#include "tsf/common/error.h"
#include "tsf/import/hu_volume_writer.h"
#include "tsf/import/imaging_library_setup.h"
#include "tsf/import/import_volume.h"
#include "tsf/import/slice_stack_geometry.h"
#include "tsf/import/slice_stack_resampler.h"

namespace fs = std::filesystem;
using tsf::import::HuImage;

namespace {

/// CPU seconds (user + system) this process and its reaped children (decoder processes) used.
double cpu_seconds() {
  double total = 0;
  for (const int who : {RUSAGE_SELF, RUSAGE_CHILDREN}) {
    rusage u{};
    getrusage(who, &u);
    total += static_cast<double>(u.ru_utime.tv_sec + u.ru_stime.tv_sec) +
             1e-6 * static_cast<double>(u.ru_utime.tv_usec + u.ru_stime.tv_usec);
  }
  return total;
}

/// The last call's CPU seconds (seconds_of measures both).
double g_last_cpu = 0;

double seconds_of(const std::function<void()>& f) {
  const double c0 = cpu_seconds();
  const auto t0 = std::chrono::steady_clock::now();
  f();
  g_last_cpu = cpu_seconds() - c0;
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  const std::size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

struct Pair {
  std::vector<double> tsf, itk, tsf_cpu, itk_cpu;
};

Pair alternate(int repeats, const std::function<void()>& tsf_run,
               const std::function<void()>& itk_run) {
  tsf_run();  // warm-up: page cache, factories, first-touch allocations
  itk_run();
  Pair p;
  for (int r = 0; r < repeats; ++r) {
    p.tsf.push_back(seconds_of(tsf_run));
    p.tsf_cpu.push_back(g_last_cpu);
    p.itk.push_back(seconds_of(itk_run));
    p.itk_cpu.push_back(g_last_cpu);
  }
  return p;
}

/// Wall-clock medians and their ratio; then the CPU medians (user + system, decoder processes
/// included), which load from other processes disturbs far less.
void print_row(const char* name, const Pair& p) {
  const double t = median(p.tsf), i = median(p.itk);
  const double tc = median(p.tsf_cpu), ic = median(p.itk_cpu);
  std::printf("| %s | %.1f | %.1f | %.2f× | %.1f | %.1f |\n", name, t * 1e3, i * 1e3, t / i,
              tc * 1e3, ic * 1e3);
}

HuImage::Pointer itk_series(const fs::path& dir, unsigned expected_slices) {
  auto names = itk::GDCMSeriesFileNames::New();
  // Series details off: with them on, ITK splits this series by slice thickness (4 / 7 mm)
  // and would read only half of the files.
  names->SetUseSeriesDetails(false);
  names->SetDirectory(dir.string());
  const auto uids = names->GetSeriesUIDs();
  if (uids.empty()) throw tsf::Error("ITK found no series in " + dir.string());
  auto reader = itk::ImageSeriesReader<HuImage>::New();
  reader->SetImageIO(itk::GDCMImageIO::New());
  reader->SetFileNames(names->GetFileNames(uids.front()));
  reader->Update();
  if (reader->GetOutput()->GetLargestPossibleRegion().GetSize()[2] != expected_slices)
    throw tsf::Error("ITK read a different number of slices than the " +
                     std::to_string(expected_slices) + " of " + dir.string());
  return reader->GetOutput();
}

/// The like-for-like peer of tsf's GE import: ITK reads the series and resamples it with
/// ResampleImageFilter (trilinear, the interpolation tsf uses) onto the grid tsf produced. ITK's
/// stacked input ignores the tilt, so the values differ; the work (decode + 14 M interpolated
/// output voxels) is the same.
HuImage::Pointer itk_series_resampled(const fs::path& dir, unsigned expected_slices,
                                      const HuImage& grid) {
  const HuImage::Pointer stacked = itk_series(dir, expected_slices);
  using Resampler = itk::ResampleImageFilter<HuImage, HuImage>;
  auto resampler = Resampler::New();
  resampler->SetInput(stacked);
  resampler->SetInterpolator(itk::LinearInterpolateImageFunction<HuImage, double>::New());
  resampler->SetOutputOrigin(grid.GetOrigin());
  resampler->SetOutputSpacing(grid.GetSpacing());
  resampler->SetOutputDirection(grid.GetDirection());
  resampler->SetSize(grid.GetLargestPossibleRegion().GetSize());
  resampler->SetDefaultPixelValue(-1024.0f);
  resampler->Update();
  return resampler->GetOutput();
}

HuImage::Pointer itk_file(const fs::path& file) {
  auto reader = itk::ImageFileReader<HuImage>::New();
  reader->SetFileName(file.string());
  reader->Update();
  return reader->GetOutput();
}

/// Cost of decoding compressed series in decoder processes (docs/robustness.md, "Containment of
/// the decoders"): the GE series encoded by GDCM in each codec, imported alternately with the
/// decoders in their processes and inside tsf (TSF_DECODE_IN_PROCESS=1), same options.
void containment_cost(const fs::path& ge, int repeats, const tsf::import::ImportOptions& options) {
  const fs::path dir = fs::temp_directory_path() / "tsf-bench-import-codecs";
  struct Codec {
    const char* name;
    gdcm::TransferSyntax::TSType syntax;
  };
  const Codec codecs[] = {{"RLE Lossless", gdcm::TransferSyntax::RLELossless},
                          {"JPEG Lossless SV1", gdcm::TransferSyntax::JPEGLosslessProcess14_1},
                          {"JPEG-LS Lossless", gdcm::TransferSyntax::JPEGLSLossless},
                          {"JPEG 2000 Lossless", gdcm::TransferSyntax::JPEG2000Lossless}};
  std::printf(
      "\nCompressed twins of the GE series (GDCM-encoded): decoders in their own processes vs "
      "inside tsf, median of %d alternating repetitions\n\n",
      repeats);
  std::printf(
      "| codec | decoder processes (ms) | inside tsf (ms) | ratio | processes CPU (ms) | inside "
      "CPU (ms) |\n|---|---|---|---|---|---|\n");
  for (const Codec& c : codecs) {
    const fs::path series = dir / c.name;
    fs::create_directories(series);
    for (const auto& e : fs::directory_iterator(ge))
      if (e.path().extension() == ".dcm" && !fs::exists(series / e.path().filename()) &&
          !tsf::test::transcode(e.path(), series / e.path().filename(), c.syntax))
        throw tsf::Error(std::string("GDCM cannot encode the GE series in ") + c.name);
    const Pair p = alternate(
        repeats,
        [&] {
          unsetenv("TSF_DECODE_IN_PROCESS");
          tsf::import::import_volume(series, options);
        },
        [&] {
          setenv("TSF_DECODE_IN_PROCESS", "1", 1);
          tsf::import::import_volume(series, options);
          unsetenv("TSF_DECODE_IN_PROCESS");
        });
    print_row(c.name, p);
  }
  std::error_code ec;
  fs::remove_all(dir, ec);
}

/// Resampling knob: an analytic field sampled on a tilted, unevenly spaced stack like the GE
/// series (4 mm then 7 mm, 18.5°), resampled at several output slice spacings; RMS and max error
/// against the field at the output voxel centres that lie inside the acquired stack.
void resampling_knob(int repeats) {
  using namespace tsf;
  using namespace tsf::import;
  const int cols = 256, rows = 256;
  const double px = 0.9765625;
  const double tilt = 18.5 * 3.14159265358979 / 180;
  const Vec3d row{1, 0, 0}, column{0, std::cos(tilt), -std::sin(tilt)};
  std::vector<Vec3d> positions;
  double z = 0;
  for (int m = 0; m < 28; ++m) {
    positions.push_back({-125, -125, z});
    z += (m < 13 ? 4.0 : m == 13 ? 1.08 : 7.0) / std::cos(tilt);
  }
  // Smooth "anatomy": a sum of sines with ~30 mm wavelength, in HU-like amplitude.
  auto field = [](const Vec3d& p) {
    return 400.0 * std::sin(p.x / 9.0) * std::cos(p.y / 11.0) + 300.0 * std::sin(p.z / 7.0);
  };
  std::vector<float> stack(static_cast<std::size_t>(cols) * rows * positions.size());
  for (std::size_t m = 0; m < positions.size(); ++m)
    for (int j = 0; j < rows; ++j)
      for (int i = 0; i < cols; ++i)
        stack[(m * rows + j) * cols + i] =
            static_cast<float>(field(positions[m] + row * (i * px) + column * (j * px)));

  std::printf(
      "\nResampling knob: output slice spacing vs error on an analytic field "
      "(256²×28 tilted 18.5°, gaps 4/1.08/7 mm; field 400·sin(x/9)·cos(y/11) + "
      "300·sin(z/7) HU)\n\n");
  std::printf("| slice spacing | grid | time (ms) | RMS error (HU) | max error (HU) |\n");
  std::printf("|---|---|---|---|---|\n");
  for (double spacing : {0.0, 2.0, 1.0, 0.5}) {
    SliceStackOptions opt;
    opt.resampled_slice_spacing_mm = spacing;
    const SliceStackGeometry g =
        analyze_slice_stack(positions, {row, column}, px, px, cols, rows, opt);
    SliceStackSamples in;
    in.values = stack.data();
    in.columns = cols;
    in.rows = rows;
    in.slices = static_cast<int>(positions.size());
    in.positions = g.sorted_positions.data();
    in.row = g.axes.row;
    in.column = g.axes.column;
    in.spacing_x = in.spacing_y = px;
    std::vector<float> out(static_cast<std::size_t>(g.grid.dims.volume()));
    std::vector<double> times;
    for (int r = 0; r < std::max(3, repeats / 2); ++r)
      times.push_back(seconds_of([&] {
        resample_slice_stack(in, g.grid, {-5000.0f, false}, out.data());
      }));
    double sum2 = 0, worst = 0;
    std::int64_t n = 0;
    for (int k = 0; k < g.grid.dims.z; ++k)
      for (int j = 0; j < g.grid.dims.y; ++j)
        for (int i = 0; i < g.grid.dims.x; ++i) {
          const float v =
              out[(static_cast<std::size_t>(k) * g.grid.dims.y + j) * g.grid.dims.x + i];
          if (v == -5000.0f) continue;
          const double e = static_cast<double>(v) - field(g.grid.point(i, j, k));
          sum2 += e * e;
          worst = std::max(worst, std::abs(e));
          ++n;
        }
    std::printf("| %s | %d×%d×%d | %.1f | %.2f | %.2f |\n",
                spacing > 0
                    ? (std::to_string(spacing).substr(0, 4) + " mm").c_str()
                    : ("auto " + std::to_string(g.grid.spacing.z).substr(0, 4) + " mm").c_str(),
                g.grid.dims.x, g.grid.dims.y, g.grid.dims.z, median(times) * 1e3,
                std::sqrt(sum2 / static_cast<double>(std::max<std::int64_t>(n, 1))), worst);
  }
}

}  // namespace

int main(int argc, char** argv) {
  int repeats = 15, threads = 0;
  bool skip_containment = false;
  fs::path samples = fs::path(TSF_SOURCE_DIR) / "data-samples";
  for (int a = 1; a < argc; ++a) {
    const std::string arg = argv[a];
    if (arg == "--repeats" && a + 1 < argc)
      repeats = std::max(1, std::atoi(argv[++a]));
    else if (arg == "--threads" && a + 1 < argc)
      threads = std::atoi(argv[++a]);
    else if (arg == "--samples" && a + 1 < argc)
      samples = argv[++a];
    else if (arg == "--no-containment")
      skip_containment = true;
    else {
      std::fprintf(stderr,
                   "usage: %s [--repeats N] [--threads N] [--samples DIR] [--no-containment]\n",
                   argv[0]);
      return 2;
    }
  }
  if (threads > 0) omp_set_num_threads(threads);
  tsf::import::setup_imaging_libraries();
  const fs::path ge = samples / "ct-head-ge-hispeed-tilt-varspacing";
  const fs::path cranium = samples / "ct-head-cranium" / "cranium.nrrd";
  tsf::import::ImportOptions options;
  options.show_progress = false;
  options.reader_threads = threads;

  try {
    std::printf(
        "tsf import vs plain ITK, same run: median of %d alternating repetitions, "
        "%d OpenMP thread(s), %d cores\n\n",
        repeats, omp_get_max_threads(), omp_get_num_procs());
    std::printf(
        "| case | tsf import (ms) | plain ITK (ms) | ratio | tsf CPU (ms) | ITK CPU (ms) |\n"
        "|---|---|---|---|---|---|\n");
    tsf::import::ImportResult last;
    const Pair g = alternate(
        repeats, [&] { last = tsf::import::import_volume(ge, options); },
        [&] { itk_series(ge, 28); });
    print_row("GE head series, 28 DICOM slices → 512×486×56 resampled", g);
    const HuImage::Pointer grid = last.image;
    const Pair gr = alternate(
        repeats, [&] { last = tsf::import::import_volume(ge, options); },
        [&] { itk_series_resampled(ge, 28, *grid); });
    print_row("GE, like for like: ITK read + ResampleImageFilter (linear) onto the same grid", gr);
    const auto& s = last.report.seconds;
    const Pair c = alternate(
        repeats, [&] { tsf::import::import_volume(cranium, options); }, [&] { itk_file(cranium); });
    print_row("cranium.nrrd 256×256×108 gzip", c);
    // Like for like: a series that needs no resampling (wider corpus, when present).
    const char* env = std::getenv("TSF_SHARED_DATA");
    const fs::path shared =
        env && *env ? fs::path(env) : fs::path(TSF_SOURCE_DIR) / ".." / "shared" / "data";
    const fs::path philips =
        shared / "dicom" / "ct-head-phantom-philips-ingenuity" / "S21570" / "S2010";
    if (fs::is_directory(philips)) {
      const Pair p = alternate(
          repeats, [&] { tsf::import::import_volume(philips, options); },
          [&] { itk_series(philips, 28); });
      print_row("Philips phantom, 28 DICOM slices 512², even, no tilt (no resampling)", p);
    } else {
      std::printf("| Philips phantom (needs ../shared/data) | not run | not run | – | – | – |\n");
    }
    std::printf(
        "\nGE import stages (last run): scan %.1f ms, read %.1f ms, resample %.1f ms, "
        "total %.1f ms\n",
        s.scan * 1e3, s.read * 1e3, s.resample * 1e3, s.total * 1e3);
    if (!skip_containment) containment_cost(ge, std::max(3, repeats / 3), options);

    const fs::path out = fs::temp_directory_path() / "tsf-bench-import.nrrd";
    std::vector<double> write_gz, write_raw;
    for (int r = 0; r < std::max(3, repeats / 3); ++r) {
      write_gz.push_back(seconds_of([&] { tsf::import::write_hu_volume(out, *last.image); }));
      write_raw.push_back(seconds_of([&] {
        tsf::import::write_hu_volume(out, *last.image,
                                     {/*compress=*/false, /*compression_level=*/0});
      }));
    }
    std::error_code ec;
    fs::remove(out, ec);
    std::printf("GE write (int16 NRRD): gzip %.1f ms, uncompressed %.1f ms (not in the ratio)\n",
                median(write_gz) * 1e3, median(write_raw) * 1e3);
    resampling_knob(repeats);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bench_import: %s\n", e.what());
    return 1;
  }
  return 0;
}
