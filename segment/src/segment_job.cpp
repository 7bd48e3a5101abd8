#include "tsf/segment/segment_job.h"

#include "tsf/common/atomic_file.h"
#include "tsf/common/error.h"
#include "tsf/common/stopwatch.h"
#include "tsf/segment/hu_volume_source.h"
#include "tsf/segment/segmentation_pipeline.h"
#include "tsf/segment/segmentation_report.h"
#include "tsf/segment/sinus_anatomy.h"
#include "tsf/segment/slice_preview.h"
#include "tsf/segment/voxel_volume_boundary.h"

namespace tsf::segment {
namespace fs = std::filesystem;

SegmentJobResult run_segment_job(const SegmentJob& job) {
  require(!job.output_prefix.empty(), "tsf segment: no output prefix (-o PREFIX)");
  const std::string prefix = job.output_prefix.string();
  if (prefix.back() == '/')
    throw Error("output prefix '" + prefix +
                "' names a folder; give a prefix such as out/cranium (files become "
                "out/cranium-density.nrrd, ...)");

  Stopwatch clock;
  const HuVolumeInput imported = import_hu_volume(job.input, job.series_uid, job.show_progress);
  const HuImage::Pointer input = imported.image;
  const double read_seconds = clock.seconds();

  SegmentationOptions options;
  options.show_progress = job.show_progress;
  SegmentationResult result = segment_hu_image(input, job.preset, options);

  SegmentJobResult out;
  clock.restart();
  const VoxelVolume volume = to_voxel_volume(result.images);
  out.volume_paths = tsf::import::write_tissue_volume(job.output_prefix, volume);
  const double write_seconds = clock.seconds();

  const SegmentationStatistics stats = segmentation_statistics(result, job.preset);
  // The anatomy (nasal cavity, nose tip, nostrils, midsagittal plane, paranasal air spaces), in
  // patient coordinates; a CT that records no orientation has unknown left/right.
  clock.restart();
  SinusAnatomyOptions anatomy_options;
  for (const std::string& w : imported.warnings)
    if (w.find("orientation is not recorded") != std::string::npos)
      anatomy_options.orientation_recorded = false;
  const SinusAnatomy anatomy = find_sinus_anatomy(result.images, anatomy_options);
  result.stage_times.push_back({"anatomy", clock.seconds()});
  if (job.write_preview) {
    clock.restart();
    out.preview_path = fs::path(prefix + "-preview.png");
    SlicePreviewOptions preview_options;
    preview_options.anatomy = &anatomy;
    write_slice_preview(out.preview_path, result.images, stats, preview_options);
    result.stage_times.push_back({"preview", clock.seconds()});
  }

  nlohmann::json report = segmentation_report_json(result, stats, job.preset);
  const auto& in_spacing = input->GetSpacing();
  const auto in_size = input->GetLargestPossibleRegion().GetSize();
  report["input"] = {
      {"path", job.input.string()},
      {"dims", {in_size[0], in_size[1], in_size[2]}},
      {"spacing_mm", {in_spacing[0], in_spacing[1], in_spacing[2]}},
      {"origin_mm", {input->GetOrigin()[0], input->GetOrigin()[1], input->GetOrigin()[2]}},
      {"kind", imported.kind},
      {"series_instance_uid", imported.series_instance_uid},
      {"read_seconds", read_seconds}};
  // The import's warnings (resampling, gantry tilt, no patient orientation, ...), each as the
  // import wrote it.
  report["warnings"] = imported.warnings;
  report["anatomy"] = sinus_anatomy_json(anatomy);
  report["overrides"] = job.overrides;
  report["outputs"] = {{"density", out.volume_paths.density.string()},
                       {"labels", out.volume_paths.labels.string()},
                       {"weights", out.volume_paths.weights.string()},
                       {"preview", out.preview_path.string()},
                       {"write_seconds", write_seconds}};
  out.report_path = fs::path(prefix + "-report.json");
  report["outputs"]["report"] = out.report_path.string();
  write_text_atomically(out.report_path, report.dump(2) + "\n");
  out.report = std::move(report);
  return out;
}

}  // namespace tsf::segment
