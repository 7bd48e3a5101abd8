#include "tsf/collision/tool_contact.h"

#include <algorithm>
#include <cmath>
#include <iterator>

#include "tsf/collision/box_index.h"
#include "tsf/common/error.h"
#include "tsf/common/stopwatch.h"
#include "tsf/coupler/couple_vertex.h"

namespace tsf::collision {

namespace {

/// Whether the narrow phase keeps the render vertices out of `t` (every tool but a large body).
bool keeps_vertices_out(const WorldTool& t) {
  return t.shape != ToolShape::kField || t.field->keeps_vertices_out();
}

/// Signed distance of p from the union of `tools` (negative inside any of them), mm, the outward
/// normal of the tool it is deepest in (or nearest to) and that tool's index (−1: none). A field
/// tool's surface for lattice node `node` lies at its allowance (DistanceField::allowance_mm);
/// `vertices`: only the tools that keep render vertices out, and no allowance.
double union_distance(const std::vector<WorldTool>& tools, const Vec3d& p, std::int64_t node,
                      bool vertices, Vec3d& normal, int& which) {
  double best = 1e300;
  which = -1;
  normal = Vec3d{0, 0, 1};
  for (std::size_t i = 0; i < tools.size(); ++i) {
    const WorldTool& t = tools[i];
    if (vertices && !keeps_vertices_out(t)) continue;
    Vec3d n;
    double d = tool_distance(t, p, n);
    if (!vertices && t.shape == ToolShape::kField && node >= 0) d -= t.field->allowance_mm(node);
    if (d < best) {
      best = d;
      normal = n;
      which = static_cast<int>(i);
    }
  }
  return best;
}

/// What the steps of one resolve() read: the lattice, the nodes gathered near the tools and the
/// tools themselves.
struct ContactScene {
  const crms::LatticeGeometry& g;
  const std::vector<std::uint8_t>& anchored;  // per lattice node
  const NodeNeighbourhood& nb;
  const std::vector<WorldTool>& tools;

  /// Rest position of gathered node i, mm.
  Vec3d rest(std::size_t i) const { return g.rest_position(nb.nodes[i]); }
  /// Position of gathered node i under `displacement` (indexed like nb), mm.
  Vec3d deformed(std::size_t i, const std::vector<Vec3f>& displacement) const {
    return rest(i) + to_double(displacement[i]);
  }
  bool anchored_node(std::size_t i) const {
    return anchored[static_cast<std::size_t>(nb.nodes[i])] != 0;
  }
  /// Gathered index of corner c of the cube with lower corner cc, or −1.
  std::ptrdiff_t corner(const Int3& cc, int c) const {
    return nb.find(cc.x + coupler::corner_bit(c, 0), cc.y + coupler::corner_bit(c, 1),
                   cc.z + coupler::corner_bit(c, 2), g.dims);
  }
  /// Signed distance of lattice node `node` at p from the tools, with its normal and tool.
  double node_distance(std::int64_t node, const Vec3d& p, Vec3d& n, int& which) const {
    return union_distance(tools, p, node, false, n, which);
  }
  /// Signed distance of a render vertex at p from the tools that keep vertices out.
  double vertex_distance(const Vec3d& p, Vec3d& n) const {
    int which;
    return union_distance(tools, p, -1, true, n, which);
  }
};

/// Step 1 with other tools about (or a mesh or field tool): the nodes in the own tool's box with
/// the margin, tested against the union of every tool on the host. A node inside is sent to the
/// nearest surface of the tool it is deepest in; when that lands it inside another tool, on again
/// (a few rounds: two tools squeezing the tissue between them).
void gather_union(const crms::Solver& solver, NodeGatherer& gatherer,
                  const std::vector<WorldTool>& tools, std::size_t own, double margin_mm,
                  const crms::LatticeGeometry& g, NodeNeighbourhood& out) {
  Vec3d lo, hi;
  tool_bounds(tools[own], lo, hi);
  const Vec3d m{margin_mm, margin_mm, margin_mm};
  gatherer.gather(solver, to_float(lo - m), to_float(hi + m), std::nullopt, out);
  for (std::size_t i = 0; i < out.size(); ++i) {
    Vec3d p = g.rest_position(out.nodes[i]) + to_double(out.displacement[i]), normal;
    int which;
    double d = union_distance(tools, p, out.nodes[i], false, normal, which);
    if (!(d < 0.0)) continue;
    out.inside[i] = 1;
    out.normal[i] = to_float(normal);
    for (int round = 0; round < 4 && d < 0.0; ++round) {
      p = p - normal * (d - kContactSkinMm);
      d = union_distance(tools, p, out.nodes[i], false, normal, which);
    }
    out.target[i] = to_float(p);
  }
}

/// Step 2. Reads the held nodes, the spring forces at them and the gathered displacements;
/// writes the held nodes the tool still presses to `keep` and the others to `release` (both
/// ascending, as `held` is).
void split_held_nodes(const ContactScene& scene, const std::vector<std::int64_t>& held,
                      const std::vector<Vec3f>& forces, std::vector<std::int64_t>& keep,
                      std::vector<std::int64_t>& release) {
  for (std::size_t i = 0; i < held.size(); ++i) {
    const std::ptrdiff_t at = scene.nb.find(held[i]);
    if (at < 0) {
      release.push_back(held[i]);
      continue;
    }
    const Vec3d p = scene.deformed(static_cast<std::size_t>(at), scene.nb.displacement);
    Vec3d n;
    int which;
    const double d = scene.node_distance(held[i], p, n, which);
    if (d > 10.0 * kContactSkinMm || dot(to_double(forces[i]), n) > 0.0)
      release.push_back(held[i]);
    else
      keep.push_back(held[i]);
  }
}

/// Step 3. Reads which gathered nodes are inside the tool; writes their displacement onto the
/// nearest tool surface point to `overrides` and marks them `moved`. Anchored nodes stay.
void move_nodes_to_tool_surface(const ContactScene& scene, std::vector<Vec3f>& overrides,
                                std::vector<std::uint8_t>& moved) {
  for (std::size_t i = 0; i < scene.nb.size(); ++i) {
    if (!scene.nb.inside[i] || scene.anchored_node(i)) continue;
    overrides[i] = to_float(to_double(scene.nb.target[i]) - scene.rest(i));
    moved[i] = 1;
  }
}

/// The cubes the narrow phase tests and their coupled vertices, grouped: the vertices of cube
/// cells[k] are slots[cube_begin[k] .. cube_begin[k + 1]).
struct NarrowCubes {
  std::vector<std::int64_t> cells;  // lattice node index of each cube's lower corner, ascending
  std::vector<std::uint32_t> slots;
  std::vector<std::size_t> cube_begin;
  // Over the cells' bounding box, each cell's index in `cells` (−1: not a narrow cube); empty
  // when the box was too sparse to map (find() then searches `cells`).
  BoxIndex index;

  /// Index in `cells` of the cube with lower corner c, or −1.
  std::ptrdiff_t find(const crms::LatticeGeometry& g, const Int3& c) const {
    if (!index.empty()) return index.find(c.x, c.y, c.z);
    if (!g.contains(c.x, c.y, c.z)) return -1;
    const std::int64_t id = g.index(c.x, c.y, c.z);
    const auto it = std::lower_bound(cells.begin(), cells.end(), id);
    return it != cells.end() && *it == id ? it - cells.begin() : -1;
  }
};

/// Axis-aligned bounds of the tools that keep render vertices out.
struct ToolBoxes {
  std::vector<Vec3d> lo, hi;
  explicit ToolBoxes(const std::vector<WorldTool>& tools) {
    for (const WorldTool& t : tools) {
      if (!keeps_vertices_out(t)) continue;
      Vec3d l, h;
      tool_bounds(t, l, h);
      lo.push_back(l);
      hi.push_back(h);
    }
  }
  bool empty() const { return lo.empty(); }
  /// Whether the box [a, b] grown by `reach` meets any tool box.
  bool near(const Vec3d& a, const Vec3d& b, double reach) const {
    for (std::size_t k = 0; k < lo.size(); ++k)
      if (!(b.x + reach < lo[k].x || b.y + reach < lo[k].y || b.z + reach < lo[k].z ||
            a.x - reach > hi[k].x || a.y - reach > hi[k].y || a.z - reach > hi[k].z))
        return true;
    return false;
  }
};

/// Step 4, first half. Reads the gathered nodes' positions and the coupler's cube lists; returns
/// the cubes around every node within a lattice diagonal of a tool's bounds.
NarrowCubes cubes_near_tool(const ContactScene& scene, const coupler::Coupler& coupler,
                            const ToolBoxes& boxes) {
  const crms::LatticeGeometry& g = scene.g;
  const double reach = length(g.spacing);
  NarrowCubes cubes;
  // The cubes around each node near the tools: its 8 cubes (lower corners m − {0,1}³), marked
  // in a map over their bounding box and read back in lattice order (ascending, each once): a
  // few thousand cells, where sorting 8 entries per node took most of this step's time.
  std::vector<Int3> near;
  Int3 lo{g.dims.x, g.dims.y, g.dims.z}, hi{-1, -1, -1};
  for (std::size_t i = 0; i < scene.nb.size(); ++i) {
    const Vec3d p = scene.deformed(i, scene.nb.displacement);
    if (!boxes.near(p, p, reach)) continue;
    const Int3 m = g.coordinates(scene.nb.nodes[i]);
    near.push_back(m);
    for (int a = 0; a < 3; ++a) {
      lo[a] = std::min(lo[a], std::max(m[a] - 1, 0));
      hi[a] = std::max(hi[a], m[a]);
    }
  }
  // Calls f(c) for the lattice cells c around the nodes near the tools (with repeats).
  const auto for_each_cell = [&](auto&& f) {
    for (const Int3& m : near)
      for (int o = 0; o < 8; ++o) {
        const Int3 c{m.x - coupler::corner_bit(o, 0), m.y - coupler::corner_bit(o, 1),
                     m.z - coupler::corner_bit(o, 2)};
        if (g.contains(c.x, c.y, c.z)) f(c);
      }
  };
  const Int3 ext{hi.x - lo.x + 1, hi.y - lo.y + 1, hi.z - lo.z + 1};
  if (!near.empty() && BoxIndex::worth_it(ext.volume(), near.size())) {
    cubes.index.assign(lo, ext);
    for_each_cell([&](const Int3& c) { cubes.index.at(c.x, c.y, c.z) = 0; });
    for (int z = lo.z; z <= hi.z; ++z)
      for (int y = lo.y; y <= hi.y; ++y)
        for (int x = lo.x; x <= hi.x; ++x) {
          std::int32_t& at = cubes.index.at(x, y, z);
          if (at < 0) continue;
          at = static_cast<std::int32_t>(cubes.cells.size());
          cubes.cells.push_back(g.index(x, y, z));
        }
  } else {  // nodes spread thinly over a large box: sort the cells instead
    for_each_cell([&](const Int3& c) { cubes.cells.push_back(g.index(c.x, c.y, c.z)); });
    std::sort(cubes.cells.begin(), cubes.cells.end());
    cubes.cells.erase(std::unique(cubes.cells.begin(), cubes.cells.end()), cubes.cells.end());
  }
  for (std::int64_t c : cubes.cells) {
    cubes.cube_begin.push_back(cubes.slots.size());
    coupler.slots_in_cube(c, cubes.slots);
  }
  cubes.cube_begin.push_back(cubes.slots.size());
  // The narrow phase reads each vertex's binding and sources, scattered over the coupler's slot
  // arrays: ask for them all now, so that the loads overlap instead of waiting one by one.
  const coupler::VertexBinding* bindings = coupler.bindings().data();
  const std::uint32_t* sources = coupler.sources().data();
  for (std::uint32_t slot : cubes.slots) {
    __builtin_prefetch(bindings + slot);
    __builtin_prefetch(sources + slot);
  }
  return cubes;
}

/// The lattice's geometry as the coupler's cube-corner code reads it (no node arrays).
coupler::DeformedLatticeView lattice_geometry_view(const crms::LatticeGeometry& g) {
  coupler::DeformedLatticeView view;
  view.dims = g.dims;
  view.stride_y = g.dims.x;
  view.stride_z = static_cast<std::int64_t>(g.dims.x) * g.dims.y;
  for (int a = 0; a < 3; ++a) {
    view.origin[a] = static_cast<float>(g.origin[a]);
    view.spacing[a] = static_cast<float>(g.spacing[a]);
  }
  return view;
}

/// Step 4, second half: the narrow phase on the coupled vertices of `cubes`. Each iteration
/// maps every vertex through the corners as `overrides` displaces them; a vertex deeper than the
/// tolerance asks its cube's corners for the least-norm motion W_c·δ/ΣW² that moves it by δ
/// out along the tool normal; each node takes the longest correction asked of it.
///
/// After the first iteration only the cubes that read a node the last iteration moved are tested
/// again: the vertices of a cube whose nodes stayed are where they were, so they are as deep as
/// they were (that depth is kept per cube) and ask for what they asked before, which is nothing
/// (a vertex that asks for a correction moves one of its corners, making its cube one to test
/// again). The outcome is that of testing every cube every iteration.
class NarrowPhase {
 public:
  NarrowPhase(const ContactScene& scene, const NarrowCubes& cubes, const coupler::Coupler& coupler,
              const ContactOptions& options, const ToolBoxes& boxes, std::vector<Vec3f>& overrides)
      : scene_(scene),
        boxes_(boxes),
        cubes_(cubes),
        bindings_(coupler.bindings()),
        sources_(coupler.sources()),
        mode_(coupler.options().mode),
        view_(lattice_geometry_view(scene.g)),
        reader_{&scene.nb, view_, &overrides},
        tolerance_(options.vertex_tolerance_spacings * scene.g.min_spacing()),
        retest_every_cube_(options.retest_every_cube),
        h_max_(std::max(scene.g.spacing.x, std::max(scene.g.spacing.y, scene.g.spacing.z))),
        overrides_(overrides),
        correction_(scene.nb.size()),
        correction_len_(scene.nb.size()),
        pushed_(cubes.slots.size(), 0),
        cube_deepest_(cubes.cells.size(), 0.0),
        cube_stale_(cubes.cells.size(), 1) {}

  /// Reads and writes overrides; marks the nodes it moves in `moved`; writes out's
  /// narrow_iterations, max_vertex_depth_mm and vertices_pushed.
  void run(int max_iterations, std::vector<std::uint8_t>& moved, ContactForce& out) {
    for (int iteration = 0; iteration < max_iterations && !cubes_.slots.empty(); ++iteration) {
      const double deepest = push_vertices_out();
      out.narrow_iterations = iteration + 1;
      out.max_vertex_depth_mm = deepest;
      if (deepest <= tolerance_) {
        out.max_vertex_depth_mm = 0;
        break;
      }
      apply_corrections(moved);
      mark_stale_cubes();
    }
    for (std::uint8_t p : pushed_) out.vertices_pushed += p;
    out.narrow_cube_tests = cube_tests_;
  }

 private:
  /// One iteration: writes correction_ and correction_len_; returns the deepest vertex depth.
  double push_vertices_out() {
    std::fill(correction_len_.begin(), correction_len_.end(), 0.0f);
    double deepest = 0;
    for (std::size_t cube = 0; cube + 1 < cubes_.cube_begin.size(); ++cube) {
      if (cubes_.cube_begin[cube] == cubes_.cube_begin[cube + 1]) continue;
      if (cube_stale_[cube]) {
        ++cube_tests_;
        const Int3 cc = scene_.g.coordinates(cubes_.cells[cube]);
        cube_deepest_[cube] = cube_far_from_tool(cc) ? 0.0 : push_cube_vertices(cube, cc);
      }
      deepest = std::max(deepest, cube_deepest_[cube]);
    }
    return deepest;
  }

  /// The cubes to test in the next iteration: those that read a node the last one moved. A
  /// cube's vertices read its 8 corners and, to infer missing ones, the corners' outside
  /// neighbours (cube_corners.h: one step further along one axis), i.e. the nodes at offsets
  /// r from its lower corner with two coordinates in {0, 1} and the third in {−1, 0, 1, 2}.
  void mark_stale_cubes() {
    std::fill(cube_stale_.begin(), cube_stale_.end(),
              static_cast<std::uint8_t>(retest_every_cube_));
    if (retest_every_cube_) return;
    const crms::LatticeGeometry& g = scene_.g;
    for (std::size_t i = 0; i < correction_len_.size(); ++i) {
      if (!(correction_len_[i] > 0)) continue;
      const Int3 m = g.coordinates(scene_.nb.nodes[i]);
      for (int a = 0; a < 3; ++a) {  // the axis whose offset may reach −1 or 2
        const int b = (a + 1) % 3, c = (a + 2) % 3;
        for (int ra = -1; ra <= 2; ++ra)
          for (int rb = 0; rb <= 1; ++rb)
            for (int rc = 0; rc <= 1; ++rc) {
              if (a > 0 && (ra == 0 || ra == 1)) continue;  // the corners: counted for a = 0
              Int3 cell = m;
              cell[a] -= ra;
              cell[b] -= rb;
              cell[c] -= rc;
              const std::ptrdiff_t at = cubes_.find(g, cell);
              if (at >= 0) cube_stale_[static_cast<std::size_t>(at)] = 1;
            }
      }
    }
  }

  /// Cull: a cube's vertices lie within a spacing of its gathered corners (trilinear
  /// interpolation is a convex combination; surface vertices extrapolate by < ½ spacing).
  bool cube_far_from_tool(const Int3& cc) const {
    Vec3d clo{1e300, 1e300, 1e300}, chi{-1e300, -1e300, -1e300};
    for (int c = 0; c < 8; ++c) {
      const std::ptrdiff_t at = scene_.corner(cc, c);
      if (at < 0) continue;
      const Vec3d p = scene_.deformed(static_cast<std::size_t>(at), overrides_);
      clo = {std::min(clo.x, p.x), std::min(clo.y, p.y), std::min(clo.z, p.z)};
      chi = {std::max(chi.x, p.x), std::max(chi.y, p.y), std::max(chi.z, p.z)};
    }
    return chi.x >= clo.x && !boxes_.near(clo, chi, h_max_);
  }

  /// Tests the vertices of one cube (lower corner cc) and asks for corrections for those inside;
  /// returns the deepest depth among them (0 when none is inside).
  double push_cube_vertices(std::size_t cube, const Int3& cc) {
    double deepest = 0;
    // Vertices of one cube with the same sources share the resolved corners.
    std::uint32_t cached_sources = 0;
    bool have = false, bound = false;
    Vec3f q[8];
    const Vec3f base = view_.rest(cc.x, cc.y, cc.z);
    for (std::size_t v = cubes_.cube_begin[cube]; v < cubes_.cube_begin[cube + 1]; ++v) {
      const std::uint32_t s = cubes_.slots[v];
      const coupler::VertexBinding& b = bindings_[s];
      if (b.cell < 0) continue;
      if (!have || sources_[s] != cached_sources) {
        cached_sources = sources_[s];
        bound = coupler::resolve_cube_corners(reader_, cc, view_.spacing, cached_sources, q,
                                              nullptr, coupler::corners_needed(mode_));
        have = true;
      }
      if (!bound) continue;
      Vec3f axes[3];
      const Vec3f position = base + coupler::map_cube_point(q, b.w, mode_, axes);
      Vec3d n;
      const double d = scene_.vertex_distance(to_double(position), n);
      if (!(d < -tolerance_)) continue;
      deepest = std::max(deepest, -d);
      pushed_[v] = 1;
      push_corners(cc, sources_[s], b, n * (kContactSkinMm - d));
    }
    return deepest;
  }

  /// Least-norm corner motion moving a vertex (binding b, corner sources `sources`) by delta
  /// (trilinear weights W: corner c by W_c·δ/ΣW²); anchored and ungathered corners stay. With
  /// every corner free a corner moves at most about 2|δ|. A vertex held mostly by anchored
  /// corners (their weight above half) is pinned: it stays where the anchors keep it, inside the
  /// tool (the tool is in bone), since its few free corners would have to move |δ|/W_c, without
  /// bound as W_c → 0 (pressing tissue against anchored bone flung nodes metres away). No corner
  /// moves more than 4|δ| per iteration.
  void push_corners(const Int3& cc, std::uint32_t sources, const coupler::VertexBinding& b,
                    const Vec3d& delta) {
    std::ptrdiff_t at[8];
    double weight[8], sum_w2 = 0, anchored_w = 0, source_w = 0;
    for (int c = 0; c < 8; ++c) {
      at[c] = -1;
      weight[c] = 0;
      if (!((sources >> c) & 1u)) continue;
      at[c] = scene_.corner(cc, c);
      if (at[c] < 0) continue;
      const double w = std::max(0.0f, coupler::trilinear_weight(c, b.w));
      source_w += w;
      if (scene_.anchored_node(static_cast<std::size_t>(at[c]))) {
        anchored_w += w;
        at[c] = -1;
        continue;
      }
      weight[c] = w;
      sum_w2 += weight[c] * weight[c];
    }
    if (!(sum_w2 > 1e-12) || anchored_w > 0.5 * source_w) return;
    for (int c = 0; c < 8; ++c) {
      if (at[c] < 0 || weight[c] <= 0) continue;
      const Vec3f step = to_float(delta * std::min(weight[c] / sum_w2, kMaxCornerStepRatio));
      const float len = length(step);
      const auto i = static_cast<std::size_t>(at[c]);
      if (len > correction_len_[i]) {
        correction_len_[i] = len;
        correction_[i] = step;
      }
    }
  }

  void apply_corrections(std::vector<std::uint8_t>& moved) {
    for (std::size_t i = 0; i < correction_len_.size(); ++i)
      if (correction_len_[i] > 0) {
        overrides_[i] += correction_[i];
        moved[i] = 1;
      }
  }

  static constexpr double kMaxCornerStepRatio = 4.0;  // a corner moves at most 4|δ|
  const ContactScene& scene_;
  const ToolBoxes& boxes_;
  const NarrowCubes& cubes_;
  const std::vector<coupler::VertexBinding>& bindings_;
  const std::vector<std::uint32_t>& sources_;
  const coupler::CouplerMode mode_;
  const coupler::DeformedLatticeView view_;
  const NeighbourhoodReader reader_;
  const double tolerance_;
  const bool retest_every_cube_;
  const double h_max_;
  std::vector<Vec3f>& overrides_;
  std::vector<Vec3f> correction_;
  std::vector<float> correction_len_;
  std::vector<std::uint8_t> pushed_;      // per tested vertex
  std::vector<double> cube_deepest_;      // per cube: its deepest vertex in the last test
  std::vector<std::uint8_t> cube_stale_;  // per cube: to be tested in this iteration
  std::size_t cube_tests_ = 0;
};

/// Step 5. Constrains the moved nodes where `overrides` puts them (zero velocity) and releases the
/// let-go ones that did not move again; writes out.nodes_released and returns the nodes held now
/// (keep ∪ moved, ascending).
std::vector<std::int64_t> hold_moved_nodes(
    crms::Solver& solver, NodeGatherer& gatherer, const ContactScene& scene,
    const std::vector<Vec3f>& overrides, const std::vector<std::uint8_t>& moved,
    const std::vector<std::int64_t>& keep, const std::vector<std::int64_t>& release,
    const std::vector<std::int64_t>& held_elsewhere, ContactForce& out) {
  std::vector<std::int64_t> hold;
  std::vector<Vec3d> targets;
  for (std::size_t i = 0; i < scene.nb.size(); ++i)
    if (moved[i]) {
      hold.push_back(scene.nb.nodes[i]);
      targets.push_back(scene.deformed(i, overrides));
    }
  std::vector<std::int64_t> let_go, really_released;
  std::set_difference(release.begin(), release.end(), hold.begin(), hold.end(),
                      std::back_inserter(let_go));
  // A node another contact holds stays held: it is that contact's to let go.
  std::set_difference(let_go.begin(), let_go.end(), held_elsewhere.begin(), held_elsewhere.end(),
                      std::back_inserter(really_released));
  solver.release_and_constrain(really_released, hold, targets);  // one upload, one wait
  out.nodes_released = really_released.size();
  std::vector<std::int64_t> now;
  std::set_union(keep.begin(), keep.end(), hold.begin(), hold.end(), std::back_inserter(now));
  if (!hold.empty()) gatherer.nodes_moved(solver, hold, targets);  // released ones did not move
  return now;
}

/// Step 6. Reads the spring forces at the held nodes and their positions (`overrides` for the
/// gathered ones); writes the force and torque about the own tool's reference point.
void tool_feedback(const ContactScene& scene, const WorldTool& own,
                   const std::vector<std::int64_t>& held, const std::vector<Vec3f>& forces,
                   const std::vector<Vec3f>& overrides, ContactForce& out) {
  const Vec3d ref = own.reference_point();
  for (std::size_t i = 0; i < held.size(); ++i) {
    const Vec3d f = to_double(forces[i]);
    const std::ptrdiff_t at = scene.nb.find(held[i]);
    const Vec3d p = at >= 0 ? scene.deformed(static_cast<std::size_t>(at), overrides)
                            : scene.g.rest_position(held[i]);
    out.force_un += f;
    out.torque_un_mm += cross(p - ref, f);
  }
}

}  // namespace

ToolContact::ToolContact(const crms::LatticeGeometry& geometry, std::vector<std::uint8_t> anchored,
                         const ContactOptions& options)
    : geometry_(geometry), anchored_(std::move(anchored)), options_(options) {
  require(anchored_.size() == static_cast<std::size_t>(geometry.node_count()),
          "tool contact: the anchored flags must have one entry per lattice node");
}

void ToolContact::release_all(crms::Solver& solver,
                              const std::vector<std::int64_t>& held_elsewhere) {
  std::vector<std::int64_t> mine;
  std::set_difference(held_.begin(), held_.end(), held_elsewhere.begin(), held_elsewhere.end(),
                      std::back_inserter(mine));
  if (!mine.empty()) solver.release_nodes(mine);
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
  return resolve(solver, gatherer, coupler, std::vector<WorldTool>{tool}, 0, {});
}

ContactForce ToolContact::resolve(crms::Solver& solver, NodeGatherer& gatherer,
                                  const coupler::Coupler& coupler,
                                  const std::vector<WorldTool>& tools, std::size_t own,
                                  const std::vector<std::int64_t>& held_elsewhere) {
  require(own < tools.size(), "tool contact: resolve() needs its own tool among the tools");
  ContactForce out;
  const crms::LatticeGeometry& g = geometry_;
  Stopwatch clock;
  // Microseconds since the last lap, and the clock restarted.
  const auto lap = [&clock] {
    const double us = clock.seconds() * 1e6;
    clock.restart();
    return us;
  };
  // 1: gather. One ordinary tool alone: the gather's own exact test (the kernel's on CUDA); with
  // other tools about, or a mesh or field tool: the own tool's box, tested against every tool on
  // the host.
  const double h_max = std::max(g.spacing.x, std::max(g.spacing.y, g.spacing.z));
  const double margin = options_.margin_spacings * h_max;
  if (tools.size() == 1 && !host_only(tools[0].shape))
    gatherer.gather_around_tool(solver, tools[0], margin, nb_);
  else
    gather_union(solver, gatherer, tools, own, margin, g, nb_);
  out.nodes_gathered = nb_.size();
  out.phases_us.gather = lap();
  const ContactScene scene{g, anchored_, nb_, tools};

  // 2: release held nodes the tools no longer press.
  std::vector<std::int64_t> keep, release;
  if (!held_.empty()) {
    std::vector<Vec3f> forces;
    gatherer.spring_forces_at(solver, held_, forces);
    split_held_nodes(scene, held_, forces, keep, release);
  }
  out.phases_us.release = lap();

  // 3: nodes inside a tool go to its surface.
  std::vector<Vec3f> overrides(nb_.displacement);
  std::vector<std::uint8_t> moved(nb_.size(), 0);
  move_nodes_to_tool_surface(scene, overrides, moved);

  // 4: narrow phase on coupled vertices of the cubes around the nodes near the tools (not for a
  // body that keeps only the nodes out).
  const ToolBoxes boxes(tools);
  if (keeps_vertices_out(tools[own]) && !boxes.empty()) {
    const NarrowCubes cubes = cubes_near_tool(scene, coupler, boxes);
    out.vertices_tested = cubes.slots.size();
    NarrowPhase(scene, cubes, coupler, options_, boxes, overrides)
        .run(options_.max_narrow_iterations, moved, out);
  }
  out.phases_us.narrow = lap();

  // 5: hold the moved nodes where they now are, release the rest of the let-go ones.
  held_ = hold_moved_nodes(solver, gatherer, scene, overrides, moved, keep, release, held_elsewhere,
                           out);
  out.phases_us.hold = lap();

  // 6: what the tool feels.
  out.nodes_held = held_.size();
  if (!held_.empty()) {
    std::vector<Vec3f> forces;
    gatherer.spring_forces_at(solver, held_, forces);
    tool_feedback(scene, tools[own], held_, forces, overrides, out);
  }
  out.phases_us.feedback = lap();
  return out;
}

}  // namespace tsf::collision
