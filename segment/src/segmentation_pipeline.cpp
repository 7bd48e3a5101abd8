#include "tsf/segment/segmentation_pipeline.h"

#include <itkImageDuplicator.h>

#include <algorithm>
#include <cmath>
#include <exception>
#include <memory>
#include <sstream>

#include "tsf/common/error.h"
#include "tsf/common/progress.h"
#include "tsf/common/stopwatch.h"
#include "tsf/segment/filters/binary_distance_morphology_image_filter.h"
#include "tsf/segment/filters/body_mask_image_filter.h"
#include "tsf/segment/filters/hu_density_image_filter.h"
#include "tsf/segment/filters/hysteresis_threshold_image_filter.h"
#include "tsf/segment/filters/tissue_class_image_filter.h"
#include "tsf/segment/gaussian_smoothing.h"
#include "tsf/segment/itk_progress_bridge.h"
#include "tsf/segment/material_weights.h"
#include "tsf/segment/roi_crop.h"
#include "tsf/segment/seeded_region.h"
#include "tsf/volume/tissue_labels.h"

namespace tsf::segment {

namespace {

/// Times one stage and owns its progress bar ("segment: <stage>").
class Stage {
 public:
  Stage(SegmentationResult& result, const char* name, bool show_progress)
      : result_(result), name_(name) {
    if (show_progress)
      progress_ = std::make_unique<Progress>(std::string("segment: ") + name, 1000);
  }
  ~Stage() {
    if (progress_) {
      if (std::uncaught_exceptions() == 0) progress_->set_fraction(1.0);
      progress_->finish();
    }
    result_.stage_times.push_back({name_, clock_.seconds()});
  }
  Stage(const Stage&) = delete;
  Stage& operator=(const Stage&) = delete;
  Progress* progress() { return progress_.get(); }

 private:
  SegmentationResult& result_;
  std::string name_;
  Stopwatch clock_;
  std::unique_ptr<Progress> progress_;
};

/// Runs an ITK filter, turning its exception into a tsf::Error naming the stage.
template <typename Filter>
void run_filter(Filter* filter, const char* stage) {
  try {
    filter->Update();
  } catch (const itk::ExceptionObject& e) {
    throw Error(std::string("segment stage '") + stage + "': " + e.GetDescription());
  }
}

MaskImage::Pointer morphology(const MaskImage* mask, MorphologyOperation op, double radius_mm,
                              Progress* progress, double from, double to, const char* stage,
                              bool border_is_background = false) {
  auto filter = BinaryDistanceMorphologyImageFilter<MaskImage>::New();
  filter->SetInput(mask);
  filter->SetOperation(op);
  filter->SetRadiusMm(radius_mm);
  filter->SetBorderIsBackground(border_is_background);
  forward_itk_progress(filter, progress, from, to);
  run_filter(filter.GetPointer(), stage);
  MaskImage::Pointer out = filter->GetOutput();
  out->DisconnectPipeline();
  return out;
}

MaskImage::Pointer empty_mask_like(const HuImage* image) {
  auto mask = MaskImage::New();
  mask->CopyInformation(image);
  mask->SetRegions(image->GetLargestPossibleRegion());
  mask->Allocate();
  mask->FillBuffer(0);
  return mask;
}

double voxel_ml(const HuImage* image) {
  const auto& s = image->GetSpacing();
  return s[0] * s[1] * s[2] / 1000.0;
}

}  // namespace

SegmentationResult segment_hu_image(const HuImage* input, const SegmentPreset& preset,
                                    const SegmentationOptions& options) {
  preset.validate();
  SegmentationResult result;
  SegmentationImages& images = result.images;
  const bool show = options.show_progress;
  result.voxel_mm =
      preset.resample.voxel_mm > 0.0 ? preset.resample.voxel_mm : finest_spacing(input);

  {
    Stage stage(result, "roi", show);
    result.roi = region_of_interest(input, preset.roi, preset.body, stage.progress());
  }
  {
    Stage stage(result, "resample", show);
    images.hu = resample_isotropic(input, result.voxel_mm, result.roi, preset.resample.antialias,
                                   stage.progress());
  }
  const HuImage* hu = images.hu;
  const std::size_t n = hu->GetLargestPossibleRegion().GetNumberOfPixels();
  const unsigned int axial_axis = axial_slice_axis(hu);
  {
    Stage stage(result, "body-mask", show);
    auto body = BodyMaskImageFilter<HuImage, MaskImage>::New();
    body->SetInput(hu);
    body->SetThresholdHu(preset.body.threshold_hu);
    body->SetOpeningRadiusMm(preset.body.opening_radius_mm);
    body->SetClosingRadiusMm(preset.body.closing_radius_mm);
    body->SetFillHoles(preset.body.fill_holes);
    // The margin must reach the voxels next to the skin, diagonals included, or the mask cuts
    // into the density ramp and drags the surface inward on coarse grids.
    body->SetMarginMm(std::max(preset.body.margin_mm, std::sqrt(3.0) * result.voxel_mm));
    body->SetSliceAxis(axial_axis);
    forward_itk_progress(body, stage.progress());
    run_filter(body.GetPointer(), "body-mask");
    images.body = body->GetOutput();
    images.body->DisconnectPipeline();
  }
  HuImage::Pointer smoothed;
  {
    Stage stage(result, "smoothing", show);
    smoothed = gaussian_smooth(hu, preset.smoothing.sigma_mm, stage.progress());
  }
  {
    Stage stage(result, "density", show);
    auto density = HuDensityImageFilter<HuImage, MaskImage, DensityImage>::New();
    density->SetHuImage(smoothed);
    density->SetMaskImage(images.body);
    density->SetLowerThresholdHu(preset.density.lower.threshold_hu);
    density->SetLowerRampHu(preset.density.lower.ramp_hu);
    if (preset.density.upper) {
      density->SetUseUpperThreshold(true);
      density->SetUpperThresholdHu(preset.density.upper->threshold_hu);
      density->SetUpperRampHu(preset.density.upper->ramp_hu);
    }
    forward_itk_progress(density, stage.progress());
    run_filter(density.GetPointer(), "density");
    images.density = density->GetOutput();
    images.density->DisconnectPipeline();
  }
  MaskImage::Pointer bone;
  if (preset.bone.enabled) {
    Stage stage(result, "bone", show);
    auto hysteresis = HysteresisThresholdImageFilter<HuImage, MaskImage>::New();
    hysteresis->SetInput(smoothed);
    hysteresis->SetWeakThreshold(preset.bone.weak_hu);
    hysteresis->SetStrongThreshold(preset.bone.strong_hu);
    forward_itk_progress(hysteresis, stage.progress());
    run_filter(hysteresis.GetPointer(), "bone");
    bone = hysteresis->GetOutput();
    bone->DisconnectPipeline();
  }
  {
    Stage stage(result, "classes", show);
    auto classes = TissueClassImageFilter<HuImage, DensityImage, MaskImage, LabelImage>::New();
    classes->SetHuImage(smoothed);
    classes->SetDensityImage(images.density);
    if (bone) classes->SetBoneMask(bone);
    TissueClassRule rule;
    rule.bone_enabled = preset.bone.enabled;
    rule.cortical_hu = static_cast<float>(preset.bone.cortical_hu);
    rule.fat_enabled = preset.fat.enabled;
    rule.fat_min_hu = static_cast<float>(preset.fat.min_hu);
    rule.fat_max_hu = static_cast<float>(preset.fat.max_hu);
    classes->SetRule(rule);
    forward_itk_progress(classes, stage.progress());
    run_filter(classes.GetPointer(), "classes");
    images.labels = classes->GetOutput();
    images.labels->DisconnectPipeline();
  }
  bone = nullptr;
  unsigned char* labels = images.labels->GetBufferPointer();

  if (preset.fat.enabled && preset.fat.opening_radius_mm > 0.0) {
    // Partial volume between air (-1000) and soft tissue (~40) passes through the fat range in
    // a one-voxel shell around every air boundary; real fat is thicker than the opening ball.
    Stage stage(result, "cleanup", show);
    MaskImage::Pointer fat = empty_mask_like(hu);
    unsigned char* f = fat->GetBufferPointer();
    for (std::size_t v = 0; v < n; ++v) f[v] = labels[v] == kLabelFat ? 1 : 0;
    // A ball smaller than one voxel holds only its centre and would remove nothing.
    const double radius = std::max(preset.fat.opening_radius_mm, result.voxel_mm);
    const MaskImage::Pointer opened =
        morphology(fat, MorphologyOperation::kOpen, radius, stage.progress(), 0.0, 1.0, "cleanup");
    const unsigned char* o = opened->GetBufferPointer();
    for (std::size_t v = 0; v < n; ++v)
      if (labels[v] == kLabelFat && !o[v]) labels[v] = kLabelSoftTissue;
  }

  {
    // Air spaces: low HU, outside the tissue, deeper inside the body than min_depth_mm (so the
    // air just outside the skin, inside the body mask's margin, is not counted). Beyond the
    // scan's border is unknown: air near it is not "inside" (the mask is open at a cut face).
    Stage stage(result, "air-spaces", show);
    const MaskImage::Pointer interior =
        morphology(images.body, MorphologyOperation::kErode, preset.air_spaces.min_depth_mm,
                   stage.progress(), 0.0, 0.5, "air-spaces", true);
    images.air_spaces = empty_mask_like(hu);
    unsigned char* air = images.air_spaces->GetBufferPointer();
    const unsigned char* in = interior->GetBufferPointer();
    const float* h = smoothed->GetBufferPointer();
    const float max_hu = static_cast<float>(preset.air_spaces.max_hu);
    for (std::size_t v = 0; v < n; ++v)
      air[v] = (in[v] && labels[v] == kLabelOutside && h[v] < max_hu) ? 1 : 0;
    if (preset.mucosa.enabled && preset.mucosa.lining_mm > 0.0) {
      const MaskImage::Pointer lining =
          morphology(images.air_spaces, MorphologyOperation::kDilate, preset.mucosa.lining_mm,
                     stage.progress(), 0.5, 1.0, "air-spaces");
      const unsigned char* l = lining->GetBufferPointer();
      for (std::size_t v = 0; v < n; ++v)
        if (l[v] && labels[v] == kLabelSoftTissue) labels[v] = kLabelMucosa;
    }
  }

  if (!preset.regions.empty()) {
    Stage stage(result, "regions", show);
    const double ml_per_voxel = voxel_ml(hu);
    for (std::size_t r = 0; r < preset.regions.size(); ++r) {
      const RegionSettings& region = preset.regions[r];
      const MaskImage::Pointer grown = grow_seeded_region(smoothed, region);
      const unsigned char* g = grown->GetBufferPointer();
      RegionOutcome outcome{region.name, region.label, 0, 0};
      for (std::size_t v = 0; v < n; ++v)
        if (g[v]) ++outcome.grown_voxels;
      const double grown_ml = static_cast<double>(outcome.grown_voxels) * ml_per_voxel;
      if (grown_ml > region.max_volume_ml) {
        std::ostringstream what;
        what << "region '" << region.name << "' grew to " << grown_ml
             << " ml, more than its max_volume_ml " << region.max_volume_ml
             << " ml: it has leaked into neighbouring tissue; narrow min_hu/max_hu or move the "
                "seeds";
        throw Error(what.str());
      }
      for (std::size_t v = 0; v < n; ++v)
        if (g[v] && labels[v] != kLabelOutside) {
          labels[v] = region.label;
          ++outcome.labelled_voxels;
        }
      result.regions.push_back(outcome);
      if (stage.progress())
        stage.progress()->set_fraction(static_cast<double>(r + 1) /
                                       static_cast<double>(preset.regions.size()));
    }
  }
  smoothed = nullptr;

  if (options.compute_weights) {
    Stage stage(result, "weights", show);
    images.weights = material_weights(images.labels, preset.materials, stage.progress());
  }
  return result;
}

}  // namespace tsf::segment
