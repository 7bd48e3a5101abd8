// Frame sources: the simulation thread's side of haptics. Each step() advances what it simulates
// by dt with the stylus where the device last put it, then captures a HapticFrame around the
// stylus (haptic_frame.h) for the haptic thread.
//
//   StaticFrameSource   an undeformed voxel volume and, optionally, a surface mesh (tests,
//                       benchmarks, the analytic cases): nothing moves, windows follow the stylus
//   TissueFrameSource   a TissueModel (interaction/tissue_model.h): the stylus presses the tissue
//                       as a sphere tool while `press` is set, the solver advances, the lattice's
//                       latest snapshot, the voxels and the coupled surface are copied near the
//                       stylus, with the summed node reactions of the contact
//
// Windows reach `reach_mm` (the stylus radius) plus `margin_mm` beyond the stylus centre: the
// stylus may travel `margin_mm` between two captures before it leaves what the haptic thread
// sees (at 100 mm/s and 200 captures/s that is 0.5 mm). Capture cost: O(window voxels + window
// nodes + surface triangles) per step (the triangle scan is linear in the surface).
#pragma once

#include <memory>

#include "tsf/haptics/haptic_frame.h"
#include "tsf/haptics/stylus.h"
#include "tsf/imt/surface_mesh.h"
#include "tsf/interaction/tissue_model.h"
#include "tsf/volume/voxel_volume.h"

namespace tsf::haptics {

struct CaptureOptions {
  double reach_mm = 2.0;   ///< stylus radius, mm
  double margin_mm = 3.0;  ///< travel allowed between captures, mm
};

/// Copies the voxels within `half_extent_mm` of rest point `centre` into the frame's window.
void capture_density(const VoxelVolume& volume, const Vec3d& centre, double half_extent_mm,
                     HapticFrame& frame);
/// Copies the displacement of the lattice nodes within `half_extent_mm` of rest point `centre`
/// (plus one layer) from `positions` (#nodes×3 floats, mm, a solver snapshot).
void capture_lattice(const crms::Lattice& lattice, const float* positions, const Vec3d& centre,
                     double half_extent_mm, HapticFrame& frame);
/// Copies the triangles of `mesh` (positions deformed, normals out of the tissue) that come
/// within `reach_mm` of `centre`.
void capture_triangles(const std::vector<Vec3f>& positions, const std::vector<Vec3f>& normals,
                       const std::vector<std::array<std::uint32_t, 3>>& triangles,
                       const std::vector<std::uint8_t>* triangle_live, const Vec3d& centre,
                       double reach_mm, HapticFrame& frame);

/// What the haptic thread sees of a TissueModel around the stylus, captured by the model's owner
/// thread after it stepped (TissueFrameSource below, and a viewer's simulation thread): the
/// lattice window from the solver's latest snapshot centred on the stylus's rest point, the
/// density window through the local warp, the coupled triangles near it, and the reaction of the
/// nodes the stylus holds (given: the owner knows which tool slot is the stylus). Only the parts
/// given to set_parts() are captured (default: all): each of the others is a pass over the lattice
/// window, the voxels or every triangle of the surface, every simulation frame.
class TissueFrameCapture {
 public:
  explicit TissueFrameCapture(const CaptureOptions& options);
  /// Fills `out` around `pose` (deformed world) from `model` as it is now; `contact_force_un` and
  /// `contact_nodes` are the stylus's share of the contact (zero when it does not press).
  void capture(interaction::TissueModel& model, const StylusPose& pose,
               const Vec3d& contact_force_un, std::int64_t contact_nodes, double time_s,
               HapticFrame& out);
  const CaptureOptions& options() const { return options_; }
  /// The parts later captures fill (a force model's reads()); the others are left empty.
  void set_parts(const FrameParts& parts) { parts_ = parts; }

 private:
  CaptureOptions options_;
  FrameParts parts_;
  std::uint64_t sequence_ = 0;
  std::vector<float> snapshot_;
  std::vector<std::uint8_t> triangle_live_;
};

class FrameSource {
 public:
  virtual ~FrameSource() = default;
  /// Advances by dt_s (s) with the stylus at `pose`, pressing when `press`; captures into `out`.
  virtual void step(double dt_s, const StylusPose& pose, bool press, HapticFrame& out) = 0;
  virtual double time_s() const = 0;
};

class StaticFrameSource final : public FrameSource {
 public:
  /// `volume` and `mesh` (may be null) must outlive the source.
  StaticFrameSource(const VoxelVolume& volume, const imt::SurfaceMesh* mesh,
                    const CaptureOptions& options);
  void step(double dt_s, const StylusPose& pose, bool press, HapticFrame& out) override;
  double time_s() const override { return time_s_; }

 private:
  const VoxelVolume& volume_;
  const imt::SurfaceMesh* mesh_;
  CaptureOptions options_;
  double time_s_ = 0;
  std::uint64_t sequence_ = 0;
};

class TissueFrameSource final : public FrameSource {
 public:
  /// `model` must outlive the source; the stylus presses as a sphere of options.reach_mm.
  TissueFrameSource(interaction::TissueModel& model, const CaptureOptions& options);
  void step(double dt_s, const StylusPose& pose, bool press, HapticFrame& out) override;
  double time_s() const override { return time_s_; }
  interaction::TissueModel& model() { return model_; }

 private:
  interaction::TissueModel& model_;
  TissueFrameCapture capture_;
  interaction::Tool tool_;
  bool pressing_ = false;
  StylusPose last_pose_;
  double time_s_ = 0;
};

}  // namespace tsf::haptics
