// The mesh coupler (docs/design.md "Coupler"): every IMT render vertex follows the deformed CRMS
// lattice through the cube it is bound to, on the CPU (OpenMP) or on the GPU where the solver's
// state lives, with the per-frame and per-vertex functions of couple_vertex.h. Two passes: the
// distinct (cube, sources) frames in use are resolved once each (corners read, missing ones
// inferred), then every vertex is interpolated from its frame; a surface cube's ~5–10 vertices
// share one frame, so the inference of the surface layer's missing corners runs once per cube.
//
// Buffers are aligned with ImtSurface's vertex slots, so a viewer patches its copies by slot:
//   positions  #vertex slots, mm, deformed tissue space (freed slots: unspecified)
//   normals    #vertex slots, unit, deformed
// Only vertices that an edit touched are (re)bound: those in the IMT change list (added,
// modified, new normal — the normal picks the vertex's side of a cut), and those whose cube's
// source nodes were deleted or had springs broken (their side may have changed); freed slots are
// unbound. The result equals binding every vertex afresh (CouplerRobustness tests it). A bucket
// list per lattice cube finds the latter without scanning the surface.
//
// Dirty tracking for uploads: slots are grouped in blocks of kDirtyBlockSlots; every couple()
// or couple_slots() advances version() and stamps the blocks whose output changed, so a reader
// that last copied at version v re-copies the blocks with block_versions()[b] > v.
//
// Threading: one owner thread calls everything here (the simulation thread); the CPU loop is an
// OpenMP parallel for. The CUDA path runs on its own stream and synchronises before returning,
// so the solver's next step never races it. Not for use while Solver::step_async() is in flight.
#pragma once

#include <cstdint>
#include <memory>
#include <utility>
#include <vector>

#include "tsf/common/vec3.h"
#include "tsf/coupler/couple_vertex.h"
#include "tsf/coupler/deformed_lattice_view.h"
#include "tsf/coupler/frame_index.h"
#include "tsf/coupler/vertex_binder.h"
#include "tsf/crms/lattice.h"
#include "tsf/crms/solver.h"
#include "tsf/imt/imt_surface.h"

namespace tsf::coupler {

class CouplerDevice;

constexpr std::uint32_t kDirtyBlockSlots = 256;

struct CouplerOptions {
  CouplerMode mode = CouplerMode::kTrilinear;
  /// On CUDA, page-lock the host output arrays so that the changed blocks come back at the bus's
  /// speed; false leaves them pageable (the driver stages every copy: several times slower; kept
  /// for the benchmark's comparison).
  bool page_locked_outputs = true;
};

/// What one rebinding pass did.
struct RebindReport {
  std::size_t rebound = 0;        ///< vertices (re)bound
  std::size_t from_changes = 0;   ///< of which from the IMT change list
  std::size_t from_topology = 0;  ///< of which only because their cube's sources changed
  std::size_t unbound = 0;        ///< freed slots
  std::size_t orphans = 0;        ///< of the rebound: no alive node near (kept at rest)
  std::size_t cubes_touched = 0;  ///< cubes whose sources changed
  bool full_rebind = false;       ///< the surface buffers were reallocated
  /// Seconds by phase: the slots to bind (change lists and the cubes whose sources changed);
  /// their cells found and sorted; the bindings (on the threads); the links and frames (in the
  /// sorted order, on the calling thread).
  double collect_s = 0, locate_s = 0, bind_s = 0, link_s = 0;
};

/// The deformed-lattice view of a solver's current state (device pointers on CUDA).
DeformedLatticeView deformed_lattice_view(const crms::Solver& solver);

class Coupler {
 public:
  explicit Coupler(const crms::LatticeGeometry& geometry, const CouplerOptions& options = {});
  ~Coupler();
  Coupler(const Coupler&) = delete;
  Coupler& operator=(const Coupler&) = delete;

  const CouplerOptions& options() const { return options_; }
  void set_mode(CouplerMode mode) { options_.mode = mode; }
  /// CouplerOptions::page_locked_outputs (takes effect at the next couple()).
  void set_page_locked_outputs(bool on);

  /// Binds every live vertex of `surface` (after build() or a reallocation). Multithreaded.
  RebindReport bind_all(const imt::ImtSurface& surface, const crms::Lattice& lattice);

  /// Applies a change list (take_changes()) and the topology edits made with it: `deleted_nodes`
  /// and `broken_springs` (crms node + direction) re-bind the vertices of every cube that used
  /// them as sources. The lattice must already show the edits.
  RebindReport apply_changes(const imt::ImtSurface& surface, const imt::SurfaceChanges& changes,
                             const crms::Lattice& lattice,
                             const std::vector<std::int64_t>& deleted_nodes,
                             const std::vector<crms::SpringRef>& broken_springs);

  /// Deformed positions and normals of every bound slot from the solver's current state, on the
  /// solver's backend. On CUDA the host buffers are refreshed for the blocks that changed.
  void couple(const crms::Solver& solver);
  /// Only `slots` (e.g. the vertices an edit just re-bound, so they show deformed at once).
  void couple_slots(const crms::Solver& solver, const std::vector<std::uint32_t>& slots);
  /// Seconds by phase of the last couple_slots(): the frame list made (host); the changed
  /// bindings and frames sent to the device (CUDA: packing, copies queued); the coupling and the
  /// copy back, to the end of the wait (CPU: the coupling); the outputs stamped.
  struct CoupleTiming {
    double prepare_s = 0, upload_s = 0, couple_s = 0, stamp_s = 0;
  };
  const CoupleTiming& last_couple_timing() const { return last_couple_timing_; }

  // ---- outputs (host) ----
  const std::vector<Vec3f>& positions() const { return positions_; }
  const std::vector<Vec3f>& normals() const { return normals_; }
  std::uint32_t slot_count() const { return slot_count_; }
  std::uint64_t version() const { return version_; }
  const std::vector<std::uint64_t>& block_versions() const { return block_versions_; }
  /// Slot ranges [first, last) of the blocks stamped after `since`, merged.
  std::vector<std::pair<std::uint32_t, std::uint32_t>> changed_ranges(std::uint64_t since) const;

  // ---- bindings (inspection, tests, collision narrow phase) ----
  const std::vector<VertexBinding>& bindings() const { return bindings_; }
  const std::vector<std::uint32_t>& sources() const { return sources_; }
  const std::vector<Vec3f>& rest_normals() const { return rest_normals_; }
  /// Live vertices bound to the cube whose lower corner is `cell` (a lattice node index).
  void slots_in_cube(std::int64_t cell, std::vector<std::uint32_t>& out) const;
  /// Slots re-bound by the last bind_all/apply_changes.
  const std::vector<std::uint32_t>& last_rebound() const { return last_rebound_; }
  /// Vertices currently bound as orphans (no alive node near; they stay at rest).
  std::size_t orphan_count() const;
  std::size_t bound_count() const { return bound_count_; }
  /// Distinct (cube, sources) frames in use.
  std::size_t frame_count() const { return frame_index_.size(); }

 private:
  void ensure_capacity(std::uint32_t capacity);
  void unlink(std::uint32_t slot);
  void unlink_from(std::uint32_t slot, std::int32_t cell);
  void link(std::uint32_t slot);
  void bind_slots(const imt::ImtSurface& surface, const crms::Lattice& lattice,
                  std::vector<std::uint32_t>& slots, RebindReport& report,
                  const std::vector<std::int64_t>& touched_cells);
  void sync_device(const crms::Solver& solver);
  void stamp_block(std::uint32_t block) { block_versions_[block] = version_; }
  std::uint32_t acquire_frame(std::int32_t cell, std::uint32_t sources, bool single_piece);
  void release_frame(std::uint32_t frame);
  void reset_frames();

  crms::LatticeGeometry geometry_;
  CouplerOptions options_;
  std::uint32_t capacity_ = 0;
  std::uint32_t slot_count_ = 0;
  std::vector<VertexBinding> bindings_;
  std::vector<std::uint32_t> sources_;
  std::vector<std::uint8_t> orphan_;
  std::vector<Vec3f> rest_normals_;
  std::vector<Vec3f> positions_, normals_;
  std::vector<std::uint64_t> block_versions_;
  std::uint64_t version_ = 0;
  std::size_t bound_count_ = 0;
  // Bucket lists: head per lattice node (as cube lower corner), next/prev per slot.
  std::vector<std::int32_t> head_;
  std::vector<std::int32_t> next_, prev_;
  std::vector<std::uint32_t> last_rebound_;
  CoupleTiming last_couple_timing_;
  // Frames: slots [0, frames_.size()) with reference counts, a free list and an index by key.
  std::vector<VertexFrameBinding> vertex_frames_;  ///< per vertex slot
  std::vector<CubeFrame> frames_;
  std::vector<std::uint32_t> frame_refs_;
  std::vector<std::uint32_t> free_frames_;
  FrameIndex frame_index_;
  std::vector<std::uint8_t> frame_single_;  ///< the frame's cube was one piece when bound
  std::vector<FrameCorners> frame_corners_;
  std::vector<std::uint32_t> pending_frames_;  ///< frames changed since the last device upload
  std::vector<std::uint32_t> scratch_frames_;
  std::vector<std::uint64_t> scratch_order_, scratch_sort_;
  std::vector<std::uint32_t> scratch_slots_;  ///< sort_unique's second buffer
  std::vector<std::uint8_t> cell_marks_;      ///< #nodes, all 0 between calls (apply_changes)
  /// A re-bound vertex's new binding (by its place in the sorted order) and its old cube.
  struct Rebinding {
    BindingResult result;
    std::int32_t old_cell;
    bool full;  ///< bound afresh (else: the same frame, new w)
  };
  std::vector<Rebinding> scratch_rebinding_;
  // CUDA: device mirror, slots whose binding changed since the last upload, full upload flag.
  std::unique_ptr<CouplerDevice> device_;  // after the output arrays: unregisters them first
  std::vector<std::pair<std::uint32_t, std::uint32_t>> download_ranges_;
  std::vector<std::uint32_t> pending_upload_;
  bool device_stale_ = true;
  std::uint32_t device_frame_capacity_ = 0;
  std::vector<std::uint8_t> dirty_scratch_;
};

}  // namespace tsf::coupler
