// Segmentation benchmark: where the time goes, and what accuracy costs in time.
//
//   bench_segment [--stages] [--accuracy] [--peers] [--repeat N] [--ge-voxel-mm MM]
//                 [--preview-dir DIR]   (--stages also writes DIR/{cranium,ge}-sinus-preview.png)
//
// --stages    time per stage (median of N runs) of the `sinus` preset on the bundled cranium
//             (default voxel = finest input spacing) and on the bundled GE DICOM series (read with
//             ITK's GDCM series reader), next to a baseline measured in the same run: one
//             itk::BinaryThresholdImageFilter pass over the same resampled grid (the cheapest
//             possible segmentation), so ratios survive a busy machine.
// --accuracy  a partial-volume sphere phantom (radius 25 mm, 0.5×0.5×1.0 mm "scanner" grid,
//             ±20 HU noise) segmented at several isotropic voxel sizes and smoothing strengths;
//             the 0.5 iso-surface's radius error along 500 rays (iso_radius_probe.h) beside the
//             time of segment_hu_image, against the hard-step (binary mask) baseline.
// --peers     our distance transform and Gaussian against the ITK filters they replace (time and
//             largest difference, same input, same run).
// Without flags all run. Output: Markdown tables on stdout.
#include <itkBinaryThresholdImageFilter.h>
#include <itkDiscreteGaussianImageFilter.h>
#include <itkSignedMaurerDistanceMapImageFilter.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <map>
#include <random>
#include <string>
#include <vector>

#include "tsf/common/stopwatch.h"
#include "tsf/segment/euclidean_distance_transform.h"
#include "tsf/segment/gaussian_smoothing.h"
#include "tsf/segment/hu_volume_source.h"
#include "tsf/segment/iso_radius_probe.h"
#include "tsf/segment/isotropic_resample.h"
#include "tsf/segment/segment_preset.h"
#include "tsf/segment/segmentation_pipeline.h"
#include "tsf/segment/segmentation_report.h"
#include "tsf/segment/slice_preview.h"
#include "tsf/segment/sphere_phantom.h"
#include "tsf/volume/tissue_labels.h"

namespace fs = std::filesystem;
using namespace tsf::segment;

namespace {

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.empty() ? 0.0 : v[v.size() / 2];
}

HuImage::Pointer read_ge_series(const fs::path& dir) {
  return read_hu_volume(dir, false);
}

/// Seconds for one BinaryThreshold pass over `image` (median of `repeat`).
double threshold_baseline(const HuImage* image, int repeat) {
  std::vector<double> times;
  for (int r = 0; r < repeat; ++r) {
    auto threshold = itk::BinaryThresholdImageFilter<HuImage, MaskImage>::New();
    threshold->SetInput(image);
    threshold->SetLowerThreshold(-480.0f);
    tsf::Stopwatch clock;
    threshold->Update();
    times.push_back(clock.seconds());
  }
  return median(times);
}

void stage_table(const char* name, const HuImage* input, SegmentPreset preset, int repeat,
                 const fs::path& preview) {
  std::map<std::string, std::vector<double>> times;
  std::vector<std::string> order;
  std::vector<double> totals;
  SegmentationResult last;
  for (int r = 0; r < repeat; ++r) {
    last = segment_hu_image(input, preset);
    double total = 0.0;
    for (const auto& s : last.stage_times) {
      if (!times.count(s.stage)) order.push_back(s.stage);
      times[s.stage].push_back(s.seconds);
      total += s.seconds;
    }
    totals.push_back(total);
  }
  const auto size = last.images.hu->GetLargestPossibleRegion().GetSize();
  const double baseline = threshold_baseline(last.images.hu, std::max(repeat, 5));
  const auto stats = segmentation_statistics(last, preset);
  std::printf("\n### %s — preset `%s`, %zu×%zu×%zu voxels of %.3f mm (%.1f M)\n\n", name,
              preset.name.c_str(), size[0], size[1], size[2], last.voxel_mm,
              static_cast<double>(size[0] * size[1] * size[2]) / 1e6);
  std::printf("| stage | median s (of %d) | × threshold pass |\n|---|---:|---:|\n", repeat);
  for (const auto& s : order)
    std::printf("| %s | %.3f | %.1f |\n", s.c_str(), median(times[s]), median(times[s]) / baseline);
  std::printf("| **total** | **%.3f** | **%.1f** |\n", median(totals), median(totals) / baseline);
  std::printf("| baseline: one BinaryThreshold pass | %.4f | 1.0 |\n", baseline);
  std::printf("\nClasses: ");
  for (const auto& c : stats.classes) std::printf("%s %.1f ml; ", c.name.c_str(), c.region.ml);
  std::printf("air spaces %.1f ml; body %.1f ml.\n", stats.air_spaces.ml, stats.body.ml);
  if (!preview.empty()) {
    write_slice_preview(preview, last.images, stats);
    std::printf("Preview: %s\n", preview.string().c_str());
  }
}

/// Our building blocks against the ITK filters they replace, on the resampled cranium: the
/// distance transform behind every morphology step (vs itk::SignedMaurerDistanceMapImageFilter)
/// and the Gaussian (vs itk::DiscreteGaussianImageFilter, same kernel). Same input, same run.
void peer_table(const HuImage* cranium, int repeat) {
  const HuImage::Pointer hu =
      resample_isotropic(cranium, finest_spacing(cranium), full_index_box(cranium));
  const auto size = hu->GetLargestPossibleRegion().GetSize();
  const std::size_t n = hu->GetLargestPossibleRegion().GetNumberOfPixels();
  std::printf("\n## Building blocks vs their ITK peers (cranium, %zu×%zu×%zu voxels)\n\n", size[0],
              size[1], size[2]);
  std::printf(
      "| operation | ours s | ITK s | ITK / ours | max difference |\n|---|---:|---:|---:|---:|\n");

  // Distance transform of the thresholded head (squared mm² vs ITK's signed distance, squared).
  auto threshold = itk::BinaryThresholdImageFilter<HuImage, MaskImage>::New();
  threshold->SetInput(hu);
  threshold->SetLowerThreshold(-500.0f);
  threshold->Update();
  const MaskImage* mask = threshold->GetOutput();
  std::vector<float> ours(n);
  std::vector<double> ours_t, itk_t;
  itk::Image<float, 3>::Pointer reference;
  for (int r = 0; r < repeat; ++r) {
    tsf::Stopwatch clock;
    const auto& sp = hu->GetSpacing();
    squared_distance_to_foreground(mask->GetBufferPointer(), {size[0], size[1], size[2]},
                                   {sp[0], sp[1], sp[2]}, ours.data());
    ours_t.push_back(clock.seconds());
    auto maurer = itk::SignedMaurerDistanceMapImageFilter<MaskImage, itk::Image<float, 3>>::New();
    maurer->SetInput(mask);
    maurer->SetUseImageSpacing(true);
    maurer->SetSquaredDistance(true);
    maurer->SetInsideIsPositive(false);
    clock.restart();
    maurer->Update();
    itk_t.push_back(clock.seconds());
    reference = maurer->GetOutput();
  }
  double worst = 0.0;
  for (std::size_t v = 0; v < n; ++v) {
    const double r = std::max(0.0f, reference->GetBufferPointer()[v]);  // outside: distance²
    worst = std::max(worst, std::abs(static_cast<double>(ours[v]) - r));
  }
  std::printf("| squared distance transform (mm²) | %.3f | %.3f | %.1f× | %.3g mm² |\n",
              median(ours_t), median(itk_t), median(itk_t) / median(ours_t), worst);

  for (double sigma : {0.5, 1.0, 2.0}) {
    std::vector<double> a, b;
    HuImage::Pointer mine, theirs;
    for (int r = 0; r < repeat; ++r) {
      tsf::Stopwatch clock;
      mine = gaussian_smooth(hu, sigma);
      a.push_back(clock.seconds());
      auto g = itk::DiscreteGaussianImageFilter<HuImage, HuImage>::New();
      g->SetInput(hu);
      g->SetVariance(sigma * sigma);
      g->SetUseImageSpacing(true);
      g->SetMaximumError(0.01);
      g->SetMaximumKernelWidth(1024);
      clock.restart();
      g->Update();
      b.push_back(clock.seconds());
      theirs = g->GetOutput();
    }
    double diff = 0.0;
    for (std::size_t v = 0; v < n; ++v)
      diff = std::max(diff, std::abs(static_cast<double>(mine->GetBufferPointer()[v]) -
                                     static_cast<double>(theirs->GetBufferPointer()[v])));
    std::printf("| Gaussian σ = %.1f mm (HU) | %.3f | %.3f | %.1f× | %.3g HU |\n", sigma, median(a),
                median(b), median(b) / median(a), diff);
  }
}

HuImage::Pointer noisy_sphere(double radius_mm, double noise_hu) {
  SpherePhantom phantom;
  phantom.spacing_mm = 0.5;
  phantom.spacing_z_mm = 1.0;
  phantom.radius_mm = radius_mm;
  phantom.dims = static_cast<int>(2.0 * radius_mm / 0.5) + 40;
  phantom.dims_z = static_cast<int>(2.0 * radius_mm / 1.0) + 20;
  phantom.centre_mm = {0.23, -0.31, 0.17};
  HuImage::Pointer hu = make_sphere_phantom(phantom);
  std::mt19937 random(12345);
  std::normal_distribution<float> noise(0.0f, static_cast<float>(noise_hu));
  float* p = hu->GetBufferPointer();
  for (std::size_t v = 0; v < hu->GetLargestPossibleRegion().GetNumberOfPixels(); ++v)
    p[v] += noise(random);
  return hu;
}

struct AccuracyRow {
  double voxel_mm, sigma_mm, ramp_hu;
  IsoRadiusStatistics error;
  double seconds;
  double voxels;  ///< of the segmented grid
};

AccuracyRow accuracy_point(const HuImage* hu, const SegmentPreset& base, double voxel, double sigma,
                           double ramp, int repeat, double radius, bool antialias = true) {
  SegmentPreset p = base;
  p.resample.antialias = antialias;
  p.resample.voxel_mm = voxel;
  p.smoothing.sigma_mm = sigma;
  p.density.lower.ramp_hu = ramp;
  SegmentationOptions options;
  options.compute_weights = false;  // the surface only depends on density
  std::vector<double> times;
  SegmentationResult result;
  for (int r = 0; r < repeat; ++r) {
    tsf::Stopwatch clock;
    result = segment_hu_image(hu, p, options);
    times.push_back(clock.seconds());
  }
  return {voxel,
          sigma,
          ramp,
          probe_iso_radius(result.images.density, {0.23, -0.31, 0.17}, radius),
          median(times),
          static_cast<double>(result.images.hu->GetLargestPossibleRegion().GetNumberOfPixels())};
}

void accuracy_tables(int repeat) {
  const double radius = 25.0;
  const HuImage::Pointer hu = noisy_sphere(radius, 20.0);
  const SegmentPreset base = load_segment_preset("sinus");
  const double default_ramp = base.density.lower.ramp_hu;

  std::printf("\n### Isotropic voxel size (smoothing %.2g mm, ramp %.0f HU)\n\n",
              base.smoothing.sigma_mm, default_ramp);
  std::printf(
      "Sphere radius %.0f mm, partial-volume sampled on a 0.5×0.5×1.0 mm grid with 20 HU noise; "
      "error of the density's 0.5 iso-surface along 500 rays.\n\n",
      radius);
  std::printf(
      "| voxel mm | voxels | mean abs error mm | in voxels | bias mm | max mm | time s | "
      "binary mask mean abs mm | ramp gain | no anti-aliasing mean abs mm |\n"
      "|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n");
  for (double voxel : {0.5, 0.75, 1.0, 1.5, 2.0}) {
    const AccuracyRow row =
        accuracy_point(hu, base, voxel, base.smoothing.sigma_mm, default_ramp, repeat, radius);
    const AccuracyRow step =
        accuracy_point(hu, base, voxel, base.smoothing.sigma_mm, 0.0, 1, radius);
    const AccuracyRow aliased =
        accuracy_point(hu, base, voxel, base.smoothing.sigma_mm, default_ramp, 1, radius, false);
    std::printf("| %.2f | %.2f M | %.4f | %.3f | %+.4f | %.3f | %.3f | %.4f | %.1f× | %.4f |\n",
                voxel, row.voxels / 1e6, row.error.mean_abs_error_mm,
                row.error.mean_abs_error_mm / voxel, row.error.mean_error_mm,
                row.error.max_abs_error_mm, row.seconds, step.error.mean_abs_error_mm,
                step.error.mean_abs_error_mm / row.error.mean_abs_error_mm,
                aliased.error.mean_abs_error_mm);
  }

  std::printf("\n### Smoothing strength (voxel 1.0 mm, ramp %.0f HU)\n\n", default_ramp);
  std::printf(
      "| sigma mm | mean abs error mm | bias mm | max mm | time s |\n|---:|---:|---:|---:|---:|\n");
  for (double sigma : {0.0, 0.25, 0.5, 0.75, 1.0, 1.5, 2.0}) {
    const AccuracyRow row = accuracy_point(hu, base, 1.0, sigma, default_ramp, repeat, radius);
    std::printf("| %.2f | %.4f | %+.4f | %.3f | %.3f |\n", sigma, row.error.mean_abs_error_mm,
                row.error.mean_error_mm, row.error.max_abs_error_mm, row.seconds);
  }

  std::printf("\n### Density ramp width (voxel 1.0 mm, smoothing %.2g mm)\n\n",
              base.smoothing.sigma_mm);
  std::printf("| ramp HU | mean abs error mm | bias mm | max mm |\n|---:|---:|---:|---:|\n");
  for (double ramp : {0.0, 200.0, 400.0, 800.0, 1040.0, 1600.0}) {
    const AccuracyRow row = accuracy_point(hu, base, 1.0, base.smoothing.sigma_mm, ramp, 1, radius);
    std::printf("| %.0f%s | %.4f | %+.4f | %.3f |\n", ramp, ramp == 0.0 ? " (binary)" : "",
                row.error.mean_abs_error_mm, row.error.mean_error_mm, row.error.max_abs_error_mm);
  }
}

}  // namespace

int main(int argc, char** argv) {
  bool stages = false, accuracy = false, peers = false;
  int repeat = 3;
  double ge_voxel_mm = 0.0;
  fs::path preview_dir;
  for (int a = 1; a < argc; ++a) {
    if (!std::strcmp(argv[a], "--stages")) {
      stages = true;
    } else if (!std::strcmp(argv[a], "--accuracy")) {
      accuracy = true;
    } else if (!std::strcmp(argv[a], "--peers")) {
      peers = true;
    } else if (!std::strcmp(argv[a], "--repeat") && a + 1 < argc) {
      repeat = std::max(1, std::atoi(argv[++a]));
    } else if (!std::strcmp(argv[a], "--preview-dir") && a + 1 < argc) {
      preview_dir = argv[++a];
    } else if (!std::strcmp(argv[a], "--ge-voxel-mm") && a + 1 < argc) {
      ge_voxel_mm = std::atof(argv[++a]);
    } else {
      std::fprintf(stderr,
                   "usage: %s [--stages] [--accuracy] [--peers] [--repeat N] [--ge-voxel-mm MM] "
                   "[--preview-dir DIR]\n"
                   "  --ge-voxel-mm  isotropic voxel for the GE series (default: its finest "
                   "spacing, 0.49 mm)\n",
                   argv[0]);
      return 2;
    }
  }
  if (!stages && !accuracy && !peers) stages = accuracy = peers = true;
  try {
    const fs::path samples = fs::path(TSF_SOURCE_DIR) / "data-samples";
    if (stages) {
      std::printf("## Time per stage\n");
      const auto cranium = read_hu_volume(samples / "ct-head-cranium" / "cranium.nrrd");
      auto preview = [&](const char* file) {
        return preview_dir.empty() ? fs::path() : preview_dir / file;
      };
      stage_table("cranium.nrrd", cranium, load_segment_preset("sinus"), repeat,
                  preview("cranium-sinus-preview.png"));
      const auto ge = read_ge_series(samples / "ct-head-ge-hispeed-tilt-varspacing");
      SegmentPreset preset = load_segment_preset("sinus");
      preset.resample.voxel_mm = ge_voxel_mm;
      stage_table("GE HiSpeed DICOM series (ITK GDCM reader)", ge, preset, repeat,
                  preview("ge-sinus-preview.png"));
    }
    if (peers) peer_table(read_hu_volume(samples / "ct-head-cranium" / "cranium.nrrd"), repeat);
    if (accuracy) {
      std::printf("\n## What accuracy costs in time\n");
      accuracy_tables(repeat);
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bench_segment: %s\n", e.what());
    return 1;
  }
  return 0;
}
