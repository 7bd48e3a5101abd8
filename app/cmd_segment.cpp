// `tsf segment`: HU volume -> density, tissue labels, material weights, report and preview.
#include <cstdio>
#include <memory>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "commands.h"
#include "tsf/common/error.h"
#include "tsf/common/progress.h"
#include "tsf/segment/segment_job.h"
#include "tsf/segment/segment_preset.h"

namespace tsf::app {

namespace {

struct SegmentArguments {
  std::string input;
  std::string series;
  std::string preset = "sinus";
  std::string output;
  std::optional<double> voxel_mm;
  std::optional<double> smoothing_mm;
  std::vector<double> roi_min, roi_max;
  std::optional<double> roi_margin_mm;
  bool no_preview = false;
  bool quiet = false;
};

std::string presets_help() {
  std::ostringstream s;
  s << "Presets by name (searched in order):";
  for (const auto& d : tsf::segment::segment_preset_dirs()) s << "\n  " << d.string();
  s << "\nAvailable:";
  for (const auto& n : tsf::segment::available_segment_presets()) s << " " << n;
  return s.str();
}

std::string vec_text(const std::vector<double>& v) {
  std::ostringstream s;
  s << v[0] << "," << v[1] << "," << v[2];
  return s.str();
}

void run_segment(const SegmentArguments& a) {
  tsf::segment::SegmentJob job;
  job.input = a.input;
  job.series_uid = a.series;
  job.output_prefix = a.output;
  job.preset = tsf::segment::load_segment_preset(a.preset);
  auto& p = job.preset;
  if (a.voxel_mm) {
    p.resample.voxel_mm = *a.voxel_mm;
    job.overrides.push_back("resample.voxel_mm=" + std::to_string(*a.voxel_mm));
  }
  if (a.smoothing_mm) {
    p.smoothing.sigma_mm = *a.smoothing_mm;
    job.overrides.push_back("smoothing.sigma_mm=" + std::to_string(*a.smoothing_mm));
  }
  if (!a.roi_min.empty() || !a.roi_max.empty()) {
    if (a.roi_min.size() != 3 || a.roi_max.size() != 3)
      throw Error("--roi-min and --roi-max go together, each as X,Y,Z in mm");
    p.roi.mode = tsf::segment::RoiMode::kBox;
    p.roi.box_min_mm = {a.roi_min[0], a.roi_min[1], a.roi_min[2]};
    p.roi.box_max_mm = {a.roi_max[0], a.roi_max[1], a.roi_max[2]};
    job.overrides.push_back("roi.mode=box");
    job.overrides.push_back("roi.box_min_mm=" + vec_text(a.roi_min));
    job.overrides.push_back("roi.box_max_mm=" + vec_text(a.roi_max));
  }
  if (a.roi_margin_mm) {
    p.roi.margin_mm = *a.roi_margin_mm;
    job.overrides.push_back("roi.margin_mm=" + std::to_string(*a.roi_margin_mm));
  }
  p.validate();
  job.write_preview = !a.no_preview;
  job.show_progress = !a.quiet;

  const auto result = tsf::segment::run_segment_job(job);
  const auto& r = result.report;
  // The import's warnings go to stderr even with --quiet (they are in PREFIX-report.json too).
  for (const auto& w : r["warnings"])
    std::fprintf(stderr, "tsf segment: warning: %s\n", w.get<std::string>().c_str());
  if (a.quiet) return;
  std::printf("tsf segment: %s with preset '%s' -> %d×%d×%d voxels of %.3g mm in %.2f s\n",
              a.input.c_str(), p.name.c_str(), r["grid"]["dims"][0].get<int>(),
              r["grid"]["dims"][1].get<int>(), r["grid"]["dims"][2].get<int>(),
              r["grid"]["voxel_mm"].get<double>(), r["segmentation_seconds"].get<double>());
  std::printf("  %-18s %12s %10s\n", "class", "voxels", "ml");
  for (const auto& c : r["classes"])
    std::printf("  %-18s %12zu %10.1f\n", c["name"].get<std::string>().c_str(),
                c["voxels"].get<std::size_t>(), c["ml"].get<double>());
  std::printf("  %-18s %12zu %10.1f\n", "(air spaces)",
              r["air_spaces"]["voxels"].get<std::size_t>(), r["air_spaces"]["ml"].get<double>());
  std::printf("  %-18s %12zu %10.1f\n", "(body)", r["body"]["voxels"].get<std::size_t>(),
              r["body"]["ml"].get<double>());
  std::printf("  wrote %s, %s, %s\n", result.volume_paths.density.string().c_str(),
              result.volume_paths.labels.string().c_str(),
              result.volume_paths.weights.string().c_str());
  std::printf("  wrote %s%s%s\n", result.report_path.string().c_str(),
              result.preview_path.empty() ? "" : ", ", result.preview_path.string().c_str());
}

}  // namespace

void add_segment_command(CLI::App& app) {
  auto args = std::make_shared<SegmentArguments>();
  CLI::App* sub = app.add_subcommand(
      "segment",
      "CT (HU volume) -> density in [0,1], tissue labels and material weights.\n"
      "Writes PREFIX-density.nrrd, PREFIX-labels.nrrd, PREFIX-weights.nrrd, PREFIX-report.json "
      "and PREFIX-preview.png.\nStages: ROI crop, isotropic resampling, body mask, smoothing, "
      "density ramp, bone hysteresis, classes, clean-up, air spaces and mucosa, seeded regions, "
      "material weights.");
  sub->add_option("volume", args->input,
                  "HU volume file (NRRD, MHA, NIfTI), e.g. the output of `tsf import`, or a "
                  "DICOM folder, DICOMDIR or file")
      ->required();
  sub->add_option("-s,--series", args->series,
                  "DICOM SeriesInstanceUID to segment when the folder holds several "
                  "(`tsf info FOLDER` lists them)");
  sub->add_option("-p,--preset", args->preset,
                  "preset name (sinus, head-bone, soft-tissue) or path to a YAML preset file")
      ->capture_default_str();
  sub->add_option("-o,--output", args->output,
                  "output prefix: PREFIX-density.nrrd, PREFIX-labels.nrrd, ...")
      ->required();
  sub->add_option("--voxel-mm", args->voxel_mm,
                  "isotropic voxel size in mm (overrides resample.voxel_mm; 0 = finest input "
                  "spacing)")
      ->check(CLI::Range(0.0, 10.0));
  sub->add_option("--smoothing-mm", args->smoothing_mm,
                  "Gaussian sigma in mm on HU (overrides smoothing.sigma_mm)")
      ->check(CLI::Range(0.0, 10.0));
  sub->add_option("--roi-min", args->roi_min,
                  "region of interest: minimum corner X,Y,Z in physical (LPS) mm; with --roi-max")
      ->expected(3)
      ->delimiter(',');
  sub->add_option("--roi-max", args->roi_max,
                  "region of interest: maximum corner X,Y,Z in physical (LPS) mm")
      ->expected(3)
      ->delimiter(',');
  sub->add_option("--roi-margin-mm", args->roi_margin_mm,
                  "margin around the body when cropping to it (overrides roi.margin_mm)")
      ->check(CLI::Range(0.0, 200.0));
  sub->add_flag("--no-preview", args->no_preview, "do not write PREFIX-preview.png");
  sub->add_flag("-q,--quiet", args->quiet, "no progress bars and no summary");
  sub->footer(presets_help());
  sub->callback([args] { run_segment(*args); });
}

}  // namespace tsf::app
