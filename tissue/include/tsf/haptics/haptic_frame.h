// What the haptic thread reads: a local copy of the simulation around the stylus, captured by the
// simulation thread at its own rate (frame_capture.h) and handed over through a triple buffer
// (triple_buffer.h), so the 1 kHz loop never waits for the solver, the coupler or a renderer.
//
// A frame holds only what the three force models need near the stylus:
//   density window   rest space: a box of R1 voxels, density in [0,1]   (voxel model)
//                      density   #voxels floats, x fastest, origin = centre of voxel (0,0,0), mm
//                      cells     #voxels uint8: the cube from voxel (i,j,k) to (i+1,j+1,k+1) is
//                                kCellEmpty (all 8 corners 0), kCellFull (all 1) or kCellMixed
//                                (the last layer on each axis is mixed); the voxel model reads one
//                                byte instead of eight densities away from the surface
//   lattice window   the R3 nodes around the stylus: displacement from rest (inverse warp)
//                      displacement  #nodes×3 floats, mm; alive #nodes uint8
//   triangle patch   coupled R2 triangles near the stylus, deformed world (mesh model)
//                      corners #triangles×3 Vec3f, mm; normals #triangles×3 Vec3f, unit
//   contact          Σ reactions of the lattice nodes the pressing stylus holds (lattice model)
// The models ask the views below; an empty window reads as "no tissue there".
#pragma once

#include <cstdint>
#include <vector>

#include "tsf/common/hd.h"
#include "tsf/common/vec3.h"
#include "tsf/coupler/local_warp.h"

namespace tsf::haptics {

constexpr std::uint8_t kCellEmpty = 0, kCellFull = 1, kCellMixed = 2;

/// The parts of a frame a force model reads (ForceModel::reads()): a capture fills only those,
/// so a model that needs no window (lattice: the summed reactions) costs the simulation thread
/// nothing per frame beyond the contact force.
struct FrameParts {
  bool lattice = true;    ///< the lattice window (displacements, alive)
  bool density = true;    ///< the density window
  bool triangles = true;  ///< the coupled triangles near the stylus
};

struct DensityWindowView {
  const float* density = nullptr;
  const std::uint8_t* cells = nullptr;  ///< optional classification (see above)
  Int3 dims{0, 0, 0};
  Vec3d origin{0, 0, 0};   ///< mm, rest position of voxel (0,0,0)'s centre
  Vec3d spacing{1, 1, 1};  ///< mm
  TSF_HD_INLINE bool empty() const { return density == nullptr || dims.x <= 0; }
};

/// The lattice window: coupler/local_warp.h (the inverse warp reads it).
using LatticeWindowView = coupler::LatticeWindowView;

struct TrianglePatchView {
  const Vec3f* corners = nullptr;  ///< #triangles×3, mm, deformed world
  const Vec3f* normals = nullptr;  ///< #triangles×3 vertex normals, unit, pointing out of tissue
  std::int64_t count = 0;
};

/// A trivially copyable view of a HapticFrame (what the models take).
struct HapticFrameView {
  DensityWindowView density;
  LatticeWindowView lattice;
  TrianglePatchView triangles;
  Vec3d contact_force_un{0, 0, 0};  ///< lattice model: Σ reactions of the held nodes, µN
  std::int64_t contact_nodes = 0;   ///< nodes the stylus holds
  double time_s = 0;                ///< simulation time the frame shows, s
  std::uint64_t sequence = 0;       ///< 0 = nothing captured yet
  std::int64_t published_ns = 0;    ///< steady-clock time it was published (live loops), 0: none
};

/// The owning frame. Capture reuses the vectors' capacity: after warm-up, publishing a frame
/// allocates nothing.
struct HapticFrame {
  std::vector<float> density;
  std::vector<std::uint8_t> density_cells;
  Int3 density_dims{0, 0, 0};
  Vec3d density_origin{0, 0, 0}, density_spacing{1, 1, 1};

  std::vector<Vec3f> displacement;
  std::vector<std::uint8_t> alive;
  Int3 lattice_dims{0, 0, 0};
  Vec3d lattice_origin{0, 0, 0}, lattice_spacing{1, 1, 1};

  std::vector<Vec3f> corners, normals;

  Vec3d contact_force_un{0, 0, 0};
  std::int64_t contact_nodes = 0;
  double time_s = 0;
  std::uint64_t sequence = 0;
  std::int64_t published_ns = 0;  ///< steady-clock ns when published (stamp_now), 0: not stamped

  /// Stamps the frame with the steady clock now (a live publisher, before publish()).
  void stamp_now();

  HapticFrameView view() const {
    HapticFrameView v;
    if (!density.empty())
      v.density = {density.data(),
                   density_cells.size() == density.size() ? density_cells.data() : nullptr,
                   density_dims, density_origin, density_spacing};
    if (!displacement.empty())
      v.lattice = {displacement.data(), alive.data(), lattice_dims, lattice_origin,
                   lattice_spacing};
    v.triangles = {corners.data(), normals.data(), static_cast<std::int64_t>(corners.size() / 3)};
    v.contact_force_un = contact_force_un;
    v.contact_nodes = contact_nodes;
    v.time_s = time_s;
    v.sequence = sequence;
    v.published_ns = published_ns;
    return v;
  }
};

}  // namespace tsf::haptics
