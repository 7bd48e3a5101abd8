// Tool contact (docs/design.md "Cutting, ablation, collisions"; thesis §7.3): keeps the tissue out
// of a pressing tool and reports the force it feels.
//
// One resolve() pass, on the lattice as it is now:
//   1 gather   the nodes near the tool (node_gatherer.h: broad phase + exact node test);
//   2 release  held nodes the tool no longer presses: outside it (the tool moved away) or pulled
//              off it by their springs (F·n > 0 with n the tool's outward normal: a tool pushes,
//              it never glues);
//   3 nodes    every node inside the tool moves to the nearest surface point;
//   4 vertices narrow phase on the coupled render vertices of the cubes around those nodes:
//              a vertex still inside (the lattice is coarser than the surface) pushes its cube's
//              corners out along the tool normal, corner c by W_c·δ/ΣW² (W the trilinear weights,
//              the least-norm corner motion that moves the vertex by δ), iterated until no
//              vertex is deeper than the tolerance;
//   5 hold     moved nodes are constrained there with zero velocity (Solver::constrain_nodes);
//   6 force    F_tool = Σ spring force at the held nodes (each is minus the reaction the
//              constraint supplies), torque about the tool's reference point.
// Anchored nodes (fixed by the scene) are never moved or released by the tool.
//
// Several tools at once (two hands; a tool and another tissue instance pushing this one): each
// tool has its own ToolContact and its own held nodes, so moving one hand leaves what the other
// holds alone. A contact keeps the nodes near its tool out of every tool (a node pushed out of
// one into another is pushed on, a few rounds: two tools squeezing the tissue between them), and
// never lets go of a node another contact holds (held_elsewhere). One tool alone, not a mesh or a
// field, takes the gather kernel's exact test as it always did.
#pragma once

#include <cstdint>
#include <vector>

#include "tsf/collision/node_gatherer.h"
#include "tsf/collision/world_tool.h"
#include "tsf/coupler/coupler.h"
#include "tsf/crms/solver.h"

namespace tsf::collision {

/// What the tissue does to the tool (haptics reads this).
struct ContactForce {
  Vec3d force_un{0, 0, 0};      ///< force on the tool, µN (= g·mm/s²)
  Vec3d torque_un_mm{0, 0, 0};  ///< about the tool's reference point, µN·mm
  std::size_t nodes_held = 0;   ///< lattice nodes on the tool surface
  std::size_t nodes_released = 0;
  std::size_t vertices_tested = 0;
  std::size_t vertices_pushed = 0;  ///< vertices the narrow phase moved out
  int narrow_iterations = 0;
  std::size_t narrow_cube_tests = 0;  ///< cubes whose vertices the narrow phase's iterations tested
  double max_vertex_depth_mm = 0;     ///< deepest vertex left inside (≤ tolerance normally)
  std::size_t nodes_gathered = 0;     ///< nodes near the tool (collision cost)
  /// Where the pass spent its time, µs (summed over the contacts of one publish).
  struct Phases {
    double gather = 0;    ///< step 1: the nodes near the tool (a device round trip on CUDA)
    double release = 0;   ///< step 2: the held nodes' spring forces, which of them to let go
    double narrow = 0;    ///< steps 3–4: nodes to the tool surface, the vertices' narrow phase
    double hold = 0;      ///< step 5: the moved nodes constrained, the let-go ones released
    double feedback = 0;  ///< step 6: the held nodes' spring forces, the tool's force and torque
    Phases& operator+=(const Phases& o) {
      gather += o.gather;
      release += o.release;
      narrow += o.narrow;
      hold += o.hold;
      feedback += o.feedback;
      return *this;
    }
  } phases_us;
};

/// One tool's share of a contact with several tools: the force on it from its held nodes.
struct ToolReaction {
  Vec3d force_un{0, 0, 0};      ///< on the tool, µN
  Vec3d torque_un_mm{0, 0, 0};  ///< about the tool's reference point, µN·mm
  std::size_t nodes_held = 0;
};

struct ContactOptions {
  /// Gather margin around the tool's bounds, in lattice spacings: covers the corners of every
  /// cube whose vertices can touch the tool.
  double margin_spacings = 2.5;
  /// A vertex deeper than this (fraction of the smallest spacing) is pushed out.
  double vertex_tolerance_spacings = 1e-3;
  int max_narrow_iterations = 16;
  /// Test every cube in every iteration of the narrow phase instead of only those whose nodes
  /// the last iteration moved: the reference the incremental iterations equal bit for bit
  /// (ToolContactNarrow tests, bench_collision), at the cost of the cubes that did not change.
  bool retest_every_cube = false;
};

class ToolContact {
 public:
  /// `anchored`: per lattice node, 1 for scene anchors (never moved by the tool).
  ToolContact(const crms::LatticeGeometry& geometry, std::vector<std::uint8_t> anchored,
              const ContactOptions& options = {});

  ContactForce resolve(crms::Solver& solver, NodeGatherer& gatherer,
                       const coupler::Coupler& coupler, const WorldTool& tool);
  /// `tools[own]` is this contact's tool; the nodes near it are kept out of every tool of
  /// `tools`, and the nodes another contact holds (`held_elsewhere`, ascending) are never let go
  /// by this one. The force and torque are on the own tool (its held nodes).
  ContactForce resolve(crms::Solver& solver, NodeGatherer& gatherer,
                       const coupler::Coupler& coupler, const std::vector<WorldTool>& tools,
                       std::size_t own, const std::vector<std::int64_t>& held_elsewhere);
  /// Lets go of every node the tool holds (but those another contact holds).
  void release_all(crms::Solver& solver, const std::vector<std::int64_t>& held_elsewhere = {});
  /// Forgets nodes deleted by an edit (they are no longer held).
  void forget(const std::vector<std::int64_t>& deleted_nodes);
  /// Nodes held on the tool surface now, ascending.
  const std::vector<std::int64_t>& held() const { return held_; }
  const ContactOptions& options() const { return options_; }

 private:
  crms::LatticeGeometry geometry_;
  std::vector<std::uint8_t> anchored_;
  ContactOptions options_;
  std::vector<std::int64_t> held_;
  NodeNeighbourhood nb_;
};

}  // namespace tsf::collision
