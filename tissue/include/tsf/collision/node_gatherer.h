// Collision queries against a solver's deformed lattice, on the solver's backend:
//   gather()          broad phase + exact tool-vs-node test → a NodeNeighbourhood (host).
//                     CPU: block boxes over deformed nodes (deformed_node_blocks.h), refitted
//                     lazily after state_changed(). CUDA: one thread per node tests its deformed
//                     position against the box and the tool (world_tool.h), compacted with an
//                     atomic counter and sorted on the host — no broad phase is needed at GPU
//                     node rates, and no positions cross PCIe except the gathered ones.
//   spring_forces_at() the spring force on listed nodes (node_force.h, the solver's feature
//                     set and palette): at a constrained node, minus this is the reaction the
//                     constraint supplies, so the tool feels +Σ of it.
// One owner thread (the simulation thread); the solver must not be stepping asynchronously.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <vector>

#include "tsf/collision/deformed_node_blocks.h"
#include "tsf/collision/node_neighbourhood.h"
#include "tsf/collision/world_tool.h"
#include "tsf/crms/solver.h"

namespace tsf::collision {

class CollisionDevice;

class NodeGatherer {
 public:
  explicit NodeGatherer(const crms::LatticeGeometry& geometry);
  ~NodeGatherer();
  NodeGatherer(const NodeGatherer&) = delete;
  NodeGatherer& operator=(const NodeGatherer&) = delete;

  /// Nodes moved (the solver stepped, nodes were constrained or their state set): the CPU broad
  /// phase refits at the next query. Deleting nodes, breaking springs or releasing nodes moves
  /// nothing and needs no refit.
  void state_changed() { blocks_current_ = false; }
  /// A few nodes were moved to `positions` (mm, tool constraints): the broad phase widens the
  /// boxes of their blocks instead of refitting every block.
  void nodes_moved(const crms::Solver& solver, const std::vector<std::int64_t>& nodes,
                   const std::vector<Vec3d>& positions);

  /// Alive nodes whose deformed position lies in [lo, hi] (mm); with a tool, each gets the exact
  /// tool-vs-node test.
  void gather(const crms::Solver& solver, const Vec3f& lo, const Vec3f& hi,
              const std::optional<WorldTool>& tool, NodeNeighbourhood& out);
  /// The nodes within `margin_mm` of the tool's bounds.
  void gather_around_tool(const crms::Solver& solver, const WorldTool& tool, double margin_mm,
                          NodeNeighbourhood& out);

  /// Spring forces at `nodes`, µN (gravity and loads excluded), on the solver's backend.
  void spring_forces_at(const crms::Solver& solver, const std::vector<std::int64_t>& nodes,
                        std::vector<Vec3f>& forces);

  /// CPU broad phase statistics of the last gather (0 on CUDA).
  std::size_t last_blocks_visited() const { return blocks_.last_blocks_visited(); }

 private:
  crms::LatticeGeometry geometry_;
  DeformedNodeBlocks blocks_;
  bool blocks_current_ = false;
  std::unique_ptr<CollisionDevice> device_;
};

}  // namespace tsf::collision
