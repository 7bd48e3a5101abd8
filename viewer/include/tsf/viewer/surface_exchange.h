// The hand-off of the deformed tissue surface from the simulation thread to the render thread.
//
// The simulation thread publishes after every display frame of simulation: the vertex ranges the
// coupler stamped since the last publish (coupler.h "dirty tracking") are copied into a shared
// mirror, and after an edit (ablate, cut) the triangles and labels are copied whole, since an edit
// re-meshes and re-labels. The render thread consumes what accumulated since its last frame under
// the same lock, copying only the dirty ranges into its GPU-side arrays. Buffers are aligned with
// the IMT vertex and triangle slots:
//   positions  #vertex slots × 3, mm, deformed tissue space
//   normals    #vertex slots × 3, unit
//   labels     #vertex slots, tissue label
//   triangles  #triangle slots × 3 vertex slots (freed: all three 0, renders nothing)
// Neither side waits for the other for longer than one copy of the changed data.
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <mutex>
#include <string>
#include <utility>
#include <vector>

#include "tsf/common/vec3.h"
#include "tsf/interaction/tissue_model.h"

namespace tsf::viewer {

/// The surface as the render thread last saw it (the shared mirror).
struct SurfaceBuffers {
  std::vector<Vec3f> positions;
  std::vector<Vec3f> normals;
  std::vector<std::uint8_t> labels;
  std::vector<std::array<std::uint32_t, 3>> triangles;
  std::size_t live_triangles = 0;
};

/// What changed in SurfaceBuffers since the consumer's previous call.
struct SurfaceDelta {
  /// Triangles, labels or the slot count changed: everything must be re-uploaded.
  bool topology = false;
  /// Vertex slot ranges [first, last) whose positions or normals changed (merged, ascending).
  std::vector<std::pair<std::uint32_t, std::uint32_t>> ranges;
  bool empty() const { return !topology && ranges.empty(); }
};

/// Simulation figures for the heads-up display and the live plot.
struct SimulationStats {
  std::string backend;  ///< "cpu" or "cuda"
  Int3 lattice_dims{0, 0, 0};
  std::int64_t alive_nodes = 0;
  double dt_s = 0;         ///< solver step
  double steps_per_s = 0;  ///< solver steps per wall-clock second (recent)
  double realtime = 0;     ///< simulated seconds per wall-clock second (recent)
  double simulated_s = 0;
  std::uint64_t frames = 0;  ///< display frames simulated
  Vec3d tool_force_un{0, 0, 0};
  std::size_t live_triangles = 0;
  double removed_mm3 = 0;
  std::string error;  ///< set when the simulation stopped (instability, bad tool); empty else
  std::string stability = "stable";  ///< the verdict so far (crms/stability_monitor.h)
  double dt_over_estimate = 0;       ///< dt / the stable estimate
  /// The latest exposure event ("vessel exposed: wand removed tissue 0.8 mm from it at t =
  /// 0.0123 s"), shown as a warning line in the HUD; empty when none.
  std::string warning;
};

class SurfaceExchange {
 public:
  /// Simulation thread. `topology_changed`: an edit happened since the last publish (or first
  /// call). Copies the coupler's ranges stamped since the previous publish.
  void publish(const interaction::TissueModel& model, bool topology_changed,
               const SimulationStats& stats);
  /// Simulation thread: only the stats (e.g. after an error).
  void publish_stats(const SimulationStats& stats);

  /// Render thread: calls `apply(buffers, delta)` under the lock with what changed since the
  /// previous consume (delta may be empty), and returns the latest stats.
  SimulationStats consume(
      const std::function<void(const SurfaceBuffers&, const SurfaceDelta&)>& apply);

  /// The coupler version of the last publish (for tests).
  std::uint64_t published_version() const;

 private:
  mutable std::mutex mutex_;
  SurfaceBuffers shared_;
  SurfaceDelta pending_;
  SimulationStats stats_;
  std::uint64_t coupler_version_ = 0;
  bool first_ = true;
  std::vector<std::pair<std::uint32_t, std::uint32_t>> scratch_;
};

/// Merges `add` into the ascending, disjoint ranges `into` (both [first, last)).
void merge_ranges(std::vector<std::pair<std::uint32_t, std::uint32_t>>& into,
                  const std::vector<std::pair<std::uint32_t, std::uint32_t>>& add);

}  // namespace tsf::viewer
