// The three haptic force models (thesis §8.5, docs/design.md "Haptics (1 kHz)") behind one
// interface, so the loop, the playback and a device driver never depend on which one runs.
//
//   model    reads                      cost per evaluation                 use when
//   voxel    density window, lattice    ~0.52·n³ trilinear reads (n³ grid)  probing, stiff/rigid
//            window (inverse warp)      independent of the tissue size      tissue, soft touches;
//                                                                           smooth with n ≥ 16
//   lattice  Σ node reactions (the      O(1) here; the reaction is summed   pressing that deforms
//            simulation computes them)  by the contact pass at sim rate     the tissue; coarse
//                                                                           (bumps per node)
//   mesh     coupled triangles near     #spheres × #near triangles          fine surface detail
//            the stylus                                                     matters; pops through
//                                                                           when deep
// All forces are on the stylus, µN, deformed world. evaluate() is const, allocation-free and
// thread-safe (one model may serve several loops).
#pragma once

#include <memory>
#include <string>

#include "tsf/common/vec3.h"
#include "tsf/haptics/force_law.h"
#include "tsf/haptics/haptic_frame.h"
#include "tsf/haptics/stylus.h"

namespace tsf::haptics {

enum class ForceModelKind { kVoxel, kLattice, kMesh };

const char* to_string(ForceModelKind kind);
/// "voxel" | "lattice" | "mesh"; throws tsf::Error naming the text otherwise.
ForceModelKind force_model_from_string(const std::string& text);

/// One evaluation's result.
struct HapticForce {
  Vec3d force_un{0, 0, 0};      ///< on the stylus, µN
  double intersection_mm3 = 0;  ///< voxel: Σρ·v; mesh: Σ caps (scaled); lattice: 0
  int contacts = 0;     ///< voxel: cells touched; mesh: spheres touching; lattice: nodes held
  bool warped = false;  ///< the stylus was inverse-warped by a lattice window
};

class ForceModel {
 public:
  virtual ~ForceModel() = default;
  virtual ForceModelKind kind() const = 0;
  virtual HapticForce evaluate(const HapticFrameView& frame, const StylusPose& pose) const = 0;
  /// The parts of a frame evaluate() reads (see the table above); by default all of them.
  virtual FrameParts reads() const { return {}; }
};

/// How the voxel model reads the tissue density at a stylus cell.
enum class DensitySampling {
  kTrilinear,  ///< 8 loads; the force is a smooth function of the stylus position
  kNearest,    ///< 1 load; the thesis's binary voxel test, stepwise (jitter at low resolution)
};

struct ForceModelOptions {
  double stylus_radius_mm = 2.0;
  int voxel_resolution = 16;  ///< voxel model: stylus grid cells across the diameter
  DensitySampling sampling = DensitySampling::kTrilinear;  ///< voxel model
  /// Mesh model: stylus spheres across the diameter. 1 = the stylus sphere itself (exact for a
  /// sphere stylus, cheapest); more approximate other tool shapes, with a softer onset.
  int sphere_resolution = 1;
  ForceLaw law;               ///< voxel and mesh models
  double lattice_gain = 1.0;  ///< lattice model: scale on the summed reactions

  /// Throws tsf::Error naming the field when out of range.
  void validate() const;
};

class VoxelForceModel final : public ForceModel {
 public:
  explicit VoxelForceModel(const ForceModelOptions& options);
  ForceModelKind kind() const override { return ForceModelKind::kVoxel; }
  HapticForce evaluate(const HapticFrameView& frame, const StylusPose& pose) const override;
  FrameParts reads() const override { return {true, true, false}; }
  const SphereStylus& stylus() const { return stylus_; }
  const ForceLaw& law() const { return law_; }

 private:
  SphereStylus stylus_;
  ForceLaw law_;
  DensitySampling sampling_;
};

class LatticeForceModel final : public ForceModel {
 public:
  explicit LatticeForceModel(const ForceModelOptions& options);
  ForceModelKind kind() const override { return ForceModelKind::kLattice; }
  HapticForce evaluate(const HapticFrameView& frame, const StylusPose& pose) const override;
  FrameParts reads() const override { return {false, false, false}; }

 private:
  double gain_;
};

class MeshForceModel final : public ForceModel {
 public:
  explicit MeshForceModel(const ForceModelOptions& options);
  ForceModelKind kind() const override { return ForceModelKind::kMesh; }
  HapticForce evaluate(const HapticFrameView& frame, const StylusPose& pose) const override;
  FrameParts reads() const override { return {false, false, true}; }
  const SphereStylus& stylus() const { return stylus_; }

 private:
  SphereStylus stylus_;
  ForceLaw law_;
  double volume_scale_;  ///< V_stylus / Σ sphere volumes
};

std::unique_ptr<ForceModel> make_force_model(ForceModelKind kind, const ForceModelOptions& options);

}  // namespace tsf::haptics
