// Interactive Marching Tetrahedra (docs/design.md, "The pipeline" (R2); thesis §6.3): the render
// surface of a voxel volume, re-meshed only where the volume changed.
//
// Buffers are pre-allocated and addressed by slot, so the GPU copies of the coupler and the viewer
// can be patched in place:
//   positions  #vertex slots, mm (tissue space)
//   normals    #vertex slots, unit, area-weighted, pointing out of the tissue
//   labels     #vertex slots, tissue label of the tissue the vertex bounds
//   triangles  #triangle slots × 3 vertex slots, counter-clockwise seen from outside
// Vertex slot 0 is the sentinel: a freed triangle has all three indices 0 and renders as nothing
// until the slot is reused. Free vertex and triangle slots go on free lists; live vertices keep
// their slot (their id) for as long as some triangle uses them. Every vertex lies on one lattice
// edge or point (its key), which gives exact welding; reference counts free a vertex when its last
// triangle goes.
//
// update(volume, changed_voxels) re-meshes the cubes that can see the change (the changed box
// dilated by one cube, by three with vertex merging, whose decisions look two lattice steps
// around a point). A cube whose corner/centre sides are unchanged (its signature) keeps its
// triangles and slots; only near the changed voxels can their vertices move, and those are
// refreshed in place. The result equals a full build of the edited volume, vertex positions,
// labels and normals (exact fixed-point sums) included, up to slot numbering.
//
// One writer: build/update/take_changes must not run concurrently with each other or with
// readers of the buffers (copy what you need, or read between updates).
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <vector>

#include "tsf/common/vec3.h"
#include "tsf/imt/surface_mesh.h"
#include "tsf/imt/surface_options.h"
#include "tsf/volume/voxel_box.h"
#include "tsf/volume/voxel_volume.h"

namespace tsf::imt {

/// Net changes to the buffers since the previous take_changes(). A slot appears in one list.
struct SurfaceChanges {
  std::vector<std::uint32_t> vertices_added;     ///< free before, live now
  std::vector<std::uint32_t> vertices_modified;  ///< live before and now; position or label
                                                 ///< changed, or the slot holds another vertex
  std::vector<std::uint32_t> vertices_normal_changed;  ///< live before and now; only the normal
  std::vector<std::uint32_t> vertices_freed;           ///< live before, free now
  std::vector<std::uint32_t> triangles_added;          ///< live now with new indices
  std::vector<std::uint32_t> triangles_freed;  ///< live before, collapsed onto the sentinel now
  /// The buffers were rebuilt or grew: views and GPU copies must be refreshed whole.
  bool reallocated = false;

  bool empty() const {
    return !reallocated && vertices_added.empty() && vertices_modified.empty() &&
           vertices_normal_changed.empty() && vertices_freed.empty() && triangles_added.empty() &&
           triangles_freed.empty();
  }
};

/// The buffers as raw pointers (trivially copyable; valid until the next build/update).
struct SurfaceBuffersView {
  const Vec3f* positions = nullptr;          ///< #vertex_slots, mm
  const Vec3f* normals = nullptr;            ///< #vertex_slots
  const std::uint8_t* labels = nullptr;      ///< #vertex_slots
  const std::uint32_t* triangles = nullptr;  ///< #triangle_slots × 3
  std::uint32_t vertex_slots = 0;            ///< slots in use so far (live or free)
  std::uint32_t triangle_slots = 0;
};

struct SurfaceUpdateStats {
  std::size_t cubes_remeshed = 0;
  std::size_t triangles_released = 0;
  std::size_t triangles_made = 0;
  std::size_t vertices_made = 0;   ///< new vertices
  std::size_t vertices_moved = 0;  ///< existing vertices whose position or label changed
  std::size_t vertices_freed = 0;
  std::size_t chunks_meshed = 0;  ///< 32-cube chunks of the re-meshed region
  std::size_t chunks_ahead = 0;   ///< of them, with their vertices and refreshes planned ahead
  double seconds = 0;
  /// of phase_seconds[0] (classify): the chunks' windows (and, ahead, their vertex tables and
  /// refresh plans) on the threads; the rest is the serial pass over the cubes in order
  double classify_threads_seconds = 0;
  /// seconds by phase of update(), in its order (kUpdatePhases names them): what each cube holds
  /// now; the old normals taken off; new positions and triangles; unused vertices freed; the
  /// changed fans' normals.
  static constexpr int kPhases = 5;
  double phase_seconds[kPhases] = {};
};
/// Names of SurfaceUpdateStats::phase_seconds, as reports print them.
inline constexpr const char* kUpdatePhases[SurfaceUpdateStats::kPhases] = {
    "classify", "normals_off", "vertices_and_triangles", "free_vertices", "normals"};

class ImtSurface {
 public:
  /// `headroom` is the spare fraction of slots allocated beyond a full build's needs, so that
  /// edits rarely grow (reallocate) the buffers.
  explicit ImtSurface(const SurfaceOptions& options = {}, double headroom = 0.5);
  ~ImtSurface();
  ImtSurface(ImtSurface&&) noexcept;
  ImtSurface& operator=(ImtSurface&&) noexcept;
  ImtSurface(const ImtSurface&) = delete;
  ImtSurface& operator=(const ImtSurface&) = delete;

  /// Full surfacing (multithreaded, extract_surface) into fresh buffers.
  void build(const VoxelVolume& volume);
  /// Re-meshes the cubes that `changed_voxels` can affect. The volume must be the one built from
  /// (same dimensions), edited. The region goes in 32-cube chunks: one chunk is meshed on the
  /// calling thread alone; several share their lattice windows (and, 4 or more to a batch, their
  /// vertex tables and refresh plans) among the OpenMP threads, the cubes then taken in the serial
  /// order, so the outcome does not depend on the thread count.
  SurfaceUpdateStats update(const VoxelVolume& volume, const VoxelBox& changed_voxels);
  /// The chunks update(volume, changed_voxels) would re-mesh (0 when nothing; 1: no OpenMP team).
  std::size_t update_chunks(const VoxelBox& changed_voxels) const;

  const SurfaceOptions& options() const;
  bool built() const;

  // ---- buffers ---------------------------------------------------------------------------------
  std::uint32_t vertex_slot_count() const;  ///< slots [0, count) used so far
  std::uint32_t triangle_slot_count() const;
  std::uint32_t vertex_capacity() const;  ///< allocated slots
  std::uint32_t triangle_capacity() const;
  std::size_t live_vertex_count() const;
  std::size_t live_triangle_count() const;
  static constexpr std::uint32_t kSentinelVertex = 0;

  const std::vector<Vec3f>& positions() const;
  const std::vector<Vec3f>& normals() const;
  const std::vector<std::uint8_t>& labels() const;
  const std::vector<std::array<std::uint32_t, 3>>& triangles() const;
  bool vertex_live(std::uint32_t slot) const;
  bool triangle_live(std::uint32_t slot) const;
  /// The lattice key of a live vertex: (owner cube, edge or point slot), the same in every build
  /// of the same volume.
  std::uint64_t vertex_key(std::uint32_t slot) const;
  SurfaceBuffersView view() const;

  /// Net changes since the last call (or since build()), then forgets them.
  SurfaceChanges take_changes();

  /// Live vertices and triangles, re-indexed in slot order. `vertex_slots` (optional) receives
  /// each compact vertex's slot.
  SurfaceMesh compact(std::vector<std::uint32_t>* vertex_slots = nullptr) const;

  /// Bytes held by buffers, free lists and the cube records.
  std::size_t memory_bytes() const;

  /// Throws tsf::Error describing the first broken invariant (reference counts, records, free
  /// lists, normals sums, sentinel). For tests; O(size).
  void check_invariants() const;

 private:
  struct State;
  std::unique_ptr<State> s_;
};

}  // namespace tsf::imt
