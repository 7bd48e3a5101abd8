#include "tsf/collision/tool_contact.h"

#include <algorithm>
#include <cmath>

#include "tsf/common/error.h"
#include "tsf/coupler/couple_vertex.h"

namespace tsf::collision {

ToolContact::ToolContact(const crms::LatticeGeometry& geometry, std::vector<std::uint8_t> anchored,
                         const ContactOptions& options)
    : geometry_(geometry), anchored_(std::move(anchored)), options_(options) {
  require(anchored_.size() == static_cast<std::size_t>(geometry.node_count()),
          "tool contact: the anchored flags must have one entry per lattice node");
}

void ToolContact::release_all(crms::Solver& solver) {
  if (!held_.empty()) solver.release_nodes(held_);
  held_.clear();
}

void ToolContact::forget(const std::vector<std::int64_t>& deleted) {
  if (held_.empty() || deleted.empty()) return;
  std::vector<std::int64_t> keep;
  keep.reserve(held_.size());
  std::set_difference(held_.begin(), held_.end(), deleted.begin(), deleted.end(),
                      std::back_inserter(keep));
  held_.swap(keep);
}

ContactForce ToolContact::resolve(crms::Solver& solver, NodeGatherer& gatherer,
                                  const coupler::Coupler& coupler, const WorldTool& tool) {
  ContactForce out;
  const crms::LatticeGeometry& g = geometry_;
  const double h_max = std::max(g.spacing.x, std::max(g.spacing.y, g.spacing.z));
  gatherer.gather_around_tool(solver, tool, options_.margin_spacings * h_max, nb_);
  out.nodes_gathered = nb_.size();
  const std::size_t count = nb_.size();
  auto rest_of = [&](std::size_t i) { return g.rest_position(nb_.nodes[i]); };

  // 2: release held nodes the tool no longer presses.
  std::vector<std::int64_t> keep, release;
  if (!held_.empty()) {
    std::vector<Vec3f> forces;
    gatherer.spring_forces_at(solver, held_, forces);
    for (std::size_t i = 0; i < held_.size(); ++i) {
      const std::ptrdiff_t at = nb_.find(held_[i]);
      if (at < 0) {
        release.push_back(held_[i]);
        continue;
      }
      const Vec3d p = rest_of(static_cast<std::size_t>(at)) +
                      to_double(nb_.displacement[static_cast<std::size_t>(at)]);
      Vec3d n;
      const double d = tool_distance(tool, p, n);
      if (d > 10.0 * kContactSkinMm || dot(to_double(forces[i]), n) > 0.0)
        release.push_back(held_[i]);
      else
        keep.push_back(held_[i]);
    }
  }

  // 3: nodes inside the tool go to its surface.
  std::vector<Vec3f> overrides(nb_.displacement);
  std::vector<std::uint8_t> moved(count, 0);
  for (std::size_t i = 0; i < count; ++i) {
    if (!nb_.inside[i] || anchored_[static_cast<std::size_t>(nb_.nodes[i])]) continue;
    overrides[i] = to_float(to_double(nb_.target[i]) - rest_of(i));
    moved[i] = 1;
  }

  // 4: narrow phase on coupled vertices of the cubes around the nodes near the tool.
  Vec3d lo, hi;
  tool_bounds(tool, lo, hi);
  const double reach = length(g.spacing);
  std::vector<std::int64_t> cells;
  for (std::size_t i = 0; i < count; ++i) {
    const Vec3d p = rest_of(i) + to_double(nb_.displacement[i]);
    if (p.x < lo.x - reach || p.y < lo.y - reach || p.z < lo.z - reach || p.x > hi.x + reach ||
        p.y > hi.y + reach || p.z > hi.z + reach)
      continue;
    const Int3 m = g.coordinates(nb_.nodes[i]);
    for (int o = 0; o < 8; ++o) {
      const Int3 c{m.x - coupler::corner_bit(o, 0), m.y - coupler::corner_bit(o, 1),
                   m.z - coupler::corner_bit(o, 2)};
      if (g.contains(c.x, c.y, c.z)) cells.push_back(g.index(c.x, c.y, c.z));
    }
  }
  std::sort(cells.begin(), cells.end());
  cells.erase(std::unique(cells.begin(), cells.end()), cells.end());
  // The vertices of each cube, grouped: cube_begin[c] .. cube_begin[c + 1] in `slots`.
  std::vector<std::uint32_t> slots;
  std::vector<std::size_t> cube_begin;
  for (std::int64_t c : cells) {
    cube_begin.push_back(slots.size());
    coupler.slots_in_cube(c, slots);
  }
  cube_begin.push_back(slots.size());
  out.vertices_tested = slots.size();

  coupler::DeformedLatticeView view;
  view.dims = g.dims;
  view.stride_y = g.dims.x;
  view.stride_z = static_cast<std::int64_t>(g.dims.x) * g.dims.y;
  for (int a = 0; a < 3; ++a) {
    view.origin[a] = static_cast<float>(g.origin[a]);
    view.spacing[a] = static_cast<float>(g.spacing[a]);
  }
  const NeighbourhoodReader reader{&nb_, view, &overrides};
  const double tolerance = options_.vertex_tolerance_spacings * g.min_spacing();
  const auto& bindings = coupler.bindings();
  const auto& sources = coupler.sources();
  const coupler::CouplerMode mode = coupler.options().mode;
  std::vector<Vec3f> correction(count);
  std::vector<float> correction_len(count);
  std::vector<std::uint8_t> pushed(slots.size(), 0);
  for (int iteration = 0; iteration < options_.max_narrow_iterations && !slots.empty();
       ++iteration) {
    std::fill(correction_len.begin(), correction_len.end(), 0.0f);
    double deepest = 0;
    for (std::size_t cube = 0; cube + 1 < cube_begin.size(); ++cube) {
      if (cube_begin[cube] == cube_begin[cube + 1]) continue;
      // Cull the cube: its vertices lie within a spacing of its gathered corners (trilinear
      // interpolation is a convex combination; surface vertices extrapolate by < ½ spacing).
      const Int3 cc = g.coordinates(cells[cube]);
      Vec3d clo{1e300, 1e300, 1e300}, chi{-1e300, -1e300, -1e300};
      for (int c = 0; c < 8; ++c) {
        const std::ptrdiff_t at =
            nb_.find(cc.x + coupler::corner_bit(c, 0), cc.y + coupler::corner_bit(c, 1),
                     cc.z + coupler::corner_bit(c, 2), g.dims);
        if (at < 0) continue;
        const Vec3d p = rest_of(static_cast<std::size_t>(at)) +
                        to_double(overrides[static_cast<std::size_t>(at)]);
        clo = {std::min(clo.x, p.x), std::min(clo.y, p.y), std::min(clo.z, p.z)};
        chi = {std::max(chi.x, p.x), std::max(chi.y, p.y), std::max(chi.z, p.z)};
      }
      if (chi.x >= clo.x && (chi.x + h_max < lo.x || chi.y + h_max < lo.y || chi.z + h_max < lo.z ||
                             clo.x - h_max > hi.x || clo.y - h_max > hi.y || clo.z - h_max > hi.z))
        continue;
      // Vertices of one cube with the same sources share the resolved corners.
      std::uint32_t cached_sources = 0;
      bool have = false, bound = false;
      Vec3f q[8];
      const Vec3f base = view.rest(cc.x, cc.y, cc.z);
      for (std::size_t v = cube_begin[cube]; v < cube_begin[cube + 1]; ++v) {
        const std::uint32_t s = slots[v];
        const coupler::VertexBinding& b = bindings[s];
        if (b.cell < 0) continue;
        if (!have || sources[s] != cached_sources) {
          cached_sources = sources[s];
          bound = coupler::resolve_cube_corners(reader, cc, view.spacing, cached_sources, q,
                                                nullptr, coupler::corners_needed(mode));
          have = true;
        }
        if (!bound) continue;
        Vec3f axes[3];
        const Vec3f position = base + coupler::map_cube_point(q, b.w, mode, axes);
        Vec3d n;
        const double d = tool_distance(tool, to_double(position), n);
        if (!(d < -tolerance)) continue;
        deepest = std::max(deepest, -d);
        pushed[v] = 1;
        const Vec3d delta = n * (kContactSkinMm - d);
        // Least-norm corner motion moving the vertex by delta (trilinear weights).
        std::ptrdiff_t at[8];
        double weight[8], sum_w2 = 0;
        for (int c = 0; c < 8; ++c) {
          at[c] = -1;
          weight[c] = 0;
          if (!((sources[s] >> c) & 1u)) continue;
          const Int3 p{cc.x + coupler::corner_bit(c, 0), cc.y + coupler::corner_bit(c, 1),
                       cc.z + coupler::corner_bit(c, 2)};
          at[c] = nb_.find(p.x, p.y, p.z, g.dims);
          if (at[c] < 0) continue;
          if (anchored_[static_cast<std::size_t>(nb_.nodes[static_cast<std::size_t>(at[c])])]) {
            at[c] = -1;
            continue;
          }
          weight[c] = std::max(0.0f, coupler::trilinear_weight(c, b.w));
          sum_w2 += weight[c] * weight[c];
        }
        if (!(sum_w2 > 1e-12)) continue;
        for (int c = 0; c < 8; ++c) {
          if (at[c] < 0 || weight[c] <= 0) continue;
          const Vec3f step = to_float(delta * (weight[c] / sum_w2));
          const float len = length(step);
          const auto i = static_cast<std::size_t>(at[c]);
          if (len > correction_len[i]) {
            correction_len[i] = len;
            correction[i] = step;
          }
        }
      }
    }
    out.narrow_iterations = iteration + 1;
    out.max_vertex_depth_mm = deepest;
    if (deepest <= tolerance) {
      out.max_vertex_depth_mm = 0;
      break;
    }
    for (std::size_t i = 0; i < count; ++i)
      if (correction_len[i] > 0) {
        overrides[i] += correction[i];
        moved[i] = 1;
      }
  }
  for (std::uint8_t p : pushed) out.vertices_pushed += p;

  // 5: hold the moved nodes where they now are, release the rest of the let-go ones.
  std::vector<std::int64_t> hold;
  std::vector<Vec3d> targets;
  for (std::size_t i = 0; i < count; ++i)
    if (moved[i]) {
      hold.push_back(nb_.nodes[i]);
      targets.push_back(rest_of(i) + to_double(overrides[i]));
    }
  std::vector<std::int64_t> really_released;
  std::set_difference(release.begin(), release.end(), hold.begin(), hold.end(),
                      std::back_inserter(really_released));
  if (!really_released.empty()) solver.release_nodes(really_released);
  if (!hold.empty()) solver.constrain_nodes(hold, targets);
  out.nodes_released = really_released.size();
  std::vector<std::int64_t> now;
  std::set_union(keep.begin(), keep.end(), hold.begin(), hold.end(), std::back_inserter(now));
  held_.swap(now);
  if (!hold.empty()) gatherer.nodes_moved(solver, hold, targets);  // released ones did not move

  // 6: what the tool feels.
  out.nodes_held = held_.size();
  if (!held_.empty()) {
    std::vector<Vec3f> forces;
    gatherer.spring_forces_at(solver, held_, forces);
    const Vec3d ref = tool.reference_point();
    for (std::size_t i = 0; i < held_.size(); ++i) {
      const Vec3d f = to_double(forces[i]);
      const std::ptrdiff_t at = nb_.find(held_[i]);
      const Vec3d p = at >= 0 ? rest_of(static_cast<std::size_t>(at)) +
                                    to_double(overrides[static_cast<std::size_t>(at)])
                              : g.rest_position(held_[i]);
      out.force_un += f;
      out.torque_un_mm += cross(p - ref, f);
    }
  }
  return out;
}

}  // namespace tsf::collision
