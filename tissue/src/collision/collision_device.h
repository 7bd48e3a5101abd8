// The collision queries' device side (private to tissue/src/collision): the gather kernel (one
// thread per node: box test + exact tool test, compacted) and the spring forces at listed nodes.
// collision_device.cu implements it; collision_device_nocuda.cpp throws.
#pragma once

#include <cstdint>
#include <memory>
#include <vector>

#include "tsf/collision/node_neighbourhood.h"
#include "tsf/collision/world_tool.h"
#include "tsf/coupler/deformed_lattice_view.h"
#include "tsf/crms/node_state_view.h"
#include "tsf/crms/spring_constants.h"

namespace tsf::collision {

class CollisionDevice {
 public:
  virtual ~CollisionDevice() = default;
  /// Fills `out` (nodes ascending) with the alive nodes in [lo, hi]; `tool` may be null.
  virtual void gather(const coupler::DeformedLatticeView& lattice, const Vec3f& lo, const Vec3f& hi,
                      const WorldTool* tool, NodeNeighbourhood& out) = 0;
  /// Spring force on each listed node (crms::spring_force with `features`), µN.
  virtual void spring_forces_at(const crms::LatticeView& lattice, const crms::StateView& state,
                                const crms::MaterialPalette& palette, unsigned features,
                                const std::vector<std::int64_t>& nodes,
                                std::vector<Vec3f>& forces) = 0;
};

/// Throws tsf::Error with cuda_status().reason when CUDA is not built or has no device.
std::unique_ptr<CollisionDevice> make_collision_device();

}  // namespace tsf::collision
