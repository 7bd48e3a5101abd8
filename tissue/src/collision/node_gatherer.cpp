#include "tsf/collision/node_gatherer.h"

#include "collision_device.h"
#include "tsf/coupler/coupler.h"
#include "tsf/crms/effects.h"
#include "tsf/crms/node_force.h"
#include "tsf/crms/stencil.h"

namespace tsf::collision {

NodeGatherer::NodeGatherer(const crms::LatticeGeometry& geometry)
    : geometry_(geometry), blocks_(geometry.dims) {}

NodeGatherer::~NodeGatherer() = default;

void NodeGatherer::gather(const crms::Solver& solver, const Vec3f& lo, const Vec3f& hi,
                          const std::optional<WorldTool>& tool, NodeNeighbourhood& out) {
  const coupler::DeformedLatticeView view = coupler::deformed_lattice_view(solver);
  out.clear();
  out.lo = lo;
  out.hi = hi;
  if (solver.on_cuda()) {
    if (!device_) device_ = make_collision_device();
    // Mesh and field tools live on the host: the kernel takes the box, the host tests them.
    const bool on_host = tool && host_only(tool->shape);
    device_->gather(view, lo, hi, tool && !on_host ? &*tool : nullptr, out);
    out.build_index(geometry_.dims);
    if (on_host)
      for (std::size_t i = 0; i < out.nodes.size(); ++i) {
        const Int3 c = geometry_.coordinates(out.nodes[i]);
        out.inside[i] = node_in_tool(*tool, view.rest(c.x, c.y, c.z) + out.displacement[i],
                                     out.target[i], out.normal[i])
                            ? 1
                            : 0;
      }
    return;
  }
  if (!blocks_current_) {
    blocks_.refit(view);
    blocks_current_ = true;
  }
  blocks_.query(view, lo, hi, out.nodes, out.displacement);
  const std::size_t n = out.nodes.size();
  out.inside.assign(n, 0);
  out.target.assign(n, Vec3f{0, 0, 0});
  out.normal.assign(n, Vec3f{0, 0, 0});
  out.build_index(geometry_.dims);
  if (!tool) return;
  for (std::size_t i = 0; i < n; ++i) {
    const Int3 c = geometry_.coordinates(out.nodes[i]);
    const Vec3f p = view.rest(c.x, c.y, c.z) + out.displacement[i];
    out.inside[i] = node_in_tool(*tool, p, out.target[i], out.normal[i]) ? 1 : 0;
  }
}

void NodeGatherer::nodes_moved(const crms::Solver& solver, const std::vector<std::int64_t>& nodes,
                               const std::vector<Vec3d>& positions) {
  if (solver.on_cuda() || !blocks_current_) return;  // CUDA: no boxes; stale: refit anyway
  blocks_.nodes_moved(nodes, positions, coupler::deformed_lattice_view(solver));
}

void NodeGatherer::gather_around_tool(const crms::Solver& solver, const WorldTool& tool,
                                      double margin_mm, NodeNeighbourhood& out) {
  Vec3d lo, hi;
  tool_bounds(tool, lo, hi);
  const Vec3d m{margin_mm, margin_mm, margin_mm};
  gather(solver, to_float(lo - m), to_float(hi + m), tool, out);
}

void NodeGatherer::spring_forces_at(const crms::Solver& solver,
                                    const std::vector<std::int64_t>& nodes,
                                    std::vector<Vec3f>& forces) {
  forces.assign(nodes.size(), Vec3f{0, 0, 0});
  if (nodes.empty()) return;
  const crms::LatticeView lat = solver.lattice_view();
  const crms::StateView st = solver.state_view();
  if (solver.on_cuda()) {
    if (!device_) device_ = make_collision_device();
    device_->spring_forces_at(lat, st, solver.palette(), solver.features(), nodes, forces);
    return;
  }
  const crms::MaterialPalette& palette = solver.palette();
  crms::dispatch_features(solver.features(), [&](auto f) {
    constexpr unsigned F = decltype(f)::value;
    for (std::size_t i = 0; i < nodes.size(); ++i) {
      const std::int64_t n = nodes[i];
      if (n < 0 || n >= lat.count || !(lat.flags[n] & crms::kAliveBit)) continue;
      const Int3 c = geometry_.coordinates(n);
      const crms::IndexedStencil s{lat, st, n, c.x, c.y, c.z};
      forces[i] = crms::spring_force<F>(s, lat.rest_length, palette);
    }
  });
}

}  // namespace tsf::collision
