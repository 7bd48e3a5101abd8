// The frame a haptic device speaks in. A real device (a tracked instrument, an OpenIGTLink
// TRANSFORM, a haptic arm registered to the patient) reports poses in patient coordinates (LPS,
// mm) and takes its force in them; the tissue computes in tissue space (docs/design.md,
// "Frames": p = origin + (i, j, k)·spacing, q = origin + D·(p − origin)). The loop converts at the
// device: poses in, forces out. For most CT D = I and the two frames are the same numbers.
//
// Orientation: a tool's frame turns by Dᵀ. When D mirrors (det D < 0, a CT stored as a mirror
// image of L, P, S), Dᵀ·R is a reflection; the tool's local z is flipped to keep a rotation, which
// sphere, capsule and blade tools do not notice (a mesh tool is seen mirrored).
#pragma once

#include "tsf/volume/tool_shapes.h"
#include "tsf/volume/voxel_volume.h"

namespace tsf::haptics {

/// Where a device's poses and forces live.
enum class PoseFrame {
  kTissue,   ///< tissue space (devices inside tsf: the viewer's mouse, scripted trajectories)
  kPatient,  ///< patient LPS mm (a tracker, a network device, a registered haptic arm)
};

class DeviceFrame {
 public:
  /// Identity: tissue space is patient space.
  DeviceFrame() = default;
  /// The patient frame of the tissue: the geometry of the volume before any crop
  /// (TissueInstance::patient_frame).
  explicit DeviceFrame(const VolumeGeometry& patient_frame) : frame_(patient_frame), set_(true) {}

  /// A pose in patient LPS mm → tissue space.
  ToolPose to_tissue(const ToolPose& patient) const;
  /// A tissue-space pose → patient LPS mm (what a device at that tissue pose reports).
  ToolPose to_patient(const ToolPose& tissue) const;
  /// A tissue-space force (or any vector) → patient LPS.
  Vec3d vector_to_patient(const Vec3d& v) const {
    return set_ ? frame_.direction_to_patient(v) : v;
  }

 private:
  VolumeGeometry frame_;
  bool set_ = false;
};

}  // namespace tsf::haptics
