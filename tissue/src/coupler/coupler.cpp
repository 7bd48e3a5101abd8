#include "tsf/coupler/coupler.h"

#include <algorithm>
#include <string>

#include "coupler_device.h"
#include "tsf/common/error.h"
#include "tsf/coupler/vertex_binder.h"

namespace tsf::coupler {

DeformedLatticeView deformed_lattice_view(const crms::Solver& solver) {
  const crms::LatticeGeometry& g = solver.lattice().geometry();
  const crms::LatticeView lat = solver.lattice_view();
  const crms::StateView st = solver.state_view();
  DeformedLatticeView v;
  v.dims = g.dims;
  v.stride_y = g.dims.x;
  v.stride_z = static_cast<std::int64_t>(g.dims.x) * g.dims.y;
  for (int a = 0; a < 3; ++a) {
    v.origin[a] = static_cast<float>(g.origin[a]);
    v.spacing[a] = static_cast<float>(g.spacing[a]);
    v.u[a] = st.u[a];
  }
  v.flags = lat.flags;
  return v;
}

Coupler::Coupler(const crms::LatticeGeometry& geometry, const CouplerOptions& options)
    : geometry_(geometry), options_(options) {
  require(geometry.node_count() > 0 && geometry.node_count() < (std::int64_t{1} << 31),
          "coupler: the lattice must have between 1 and 2^31 − 1 nodes, got " +
              std::to_string(geometry.node_count()));
  head_.assign(static_cast<std::size_t>(geometry.node_count()), -1);
}

Coupler::~Coupler() = default;

void Coupler::ensure_capacity(std::uint32_t capacity) {
  if (capacity <= capacity_) return;
  bindings_.resize(capacity);
  sources_.resize(capacity, 0);
  orphan_.resize(capacity, 0);
  rest_normals_.resize(capacity);
  positions_.resize(capacity);
  normals_.resize(capacity);
  next_.resize(capacity, -1);
  prev_.resize(capacity, -1);
  block_versions_.resize((capacity + kDirtyBlockSlots - 1) / kDirtyBlockSlots, 0);
  capacity_ = capacity;
  device_stale_ = true;
}

void Coupler::unlink(std::uint32_t slot) {
  const std::int32_t cell = bindings_[slot].cell;
  if (cell < 0) return;
  const std::int32_t p = prev_[slot], n = next_[slot];
  if (p >= 0)
    next_[static_cast<std::size_t>(p)] = n;
  else
    head_[static_cast<std::size_t>(cell)] = n;
  if (n >= 0) prev_[static_cast<std::size_t>(n)] = p;
  prev_[slot] = next_[slot] = -1;
  --bound_count_;
}

void Coupler::link(std::uint32_t slot) {
  const std::int32_t cell = bindings_[slot].cell;
  const std::int32_t h = head_[static_cast<std::size_t>(cell)];
  next_[slot] = h;
  prev_[slot] = -1;
  if (h >= 0) prev_[static_cast<std::size_t>(h)] = static_cast<std::int32_t>(slot);
  head_[static_cast<std::size_t>(cell)] = static_cast<std::int32_t>(slot);
  ++bound_count_;
}

void Coupler::slots_in_cube(std::int64_t cell, std::vector<std::uint32_t>& out) const {
  if (cell < 0 || cell >= static_cast<std::int64_t>(head_.size())) return;
  for (std::int32_t s = head_[static_cast<std::size_t>(cell)]; s >= 0;
       s = next_[static_cast<std::size_t>(s)])
    out.push_back(static_cast<std::uint32_t>(s));
}

std::size_t Coupler::orphan_count() const {
  std::size_t n = 0;
  for (std::uint32_t s = 0; s < slot_count_; ++s) n += bindings_[s].cell >= 0 && orphan_[s];
  return n;
}

void Coupler::bind_slots(const imt::ImtSurface& surface, const crms::Lattice& lattice,
                         std::vector<std::uint32_t>& slots, RebindReport& report,
                         bool parallel) {
  const std::vector<Vec3f>& p = surface.positions();
  const std::vector<Vec3f>& n = surface.normals();
  // Sort by cube so consecutive vertices reuse the binder's per-cube grouping.
  std::vector<std::pair<std::int64_t, std::uint32_t>> order(slots.size());
  for (std::size_t i = 0; i < slots.size(); ++i) {
    const crms::LatticeCellLocation loc = crms::locate_rest_point(geometry_, to_double(p[slots[i]]));
    order[i] = {geometry_.index(loc.cell.x, loc.cell.y, loc.cell.z), slots[i]};
  }
  std::sort(order.begin(), order.end());
  for (std::uint32_t s : slots) unlink(s);

  const auto count = static_cast<std::int64_t>(order.size());
  std::size_t orphans = 0;
#pragma omp parallel if (parallel && count > 4096) reduction(+ : orphans)
  {
    VertexBinder binder(lattice);
#pragma omp for schedule(static)
    for (std::int64_t i = 0; i < count; ++i) {
      const std::uint32_t s = order[static_cast<std::size_t>(i)].second;
      const BindingResult r = binder.bind(p[s], n[s]);
      bindings_[s] = r.binding;
      sources_[s] = r.sources;
      orphan_[s] = r.orphan ? 1 : 0;
      rest_normals_[s] = n[s];
      orphans += r.orphan ? 1 : 0;
    }
  }
  for (const auto& o : order) {
    link(o.second);
    pending_upload_.push_back(o.second);
  }
  report.rebound += order.size();
  report.orphans += orphans;
  last_rebound_.clear();
  last_rebound_.reserve(order.size());
  for (const auto& o : order) last_rebound_.push_back(o.second);
}

RebindReport Coupler::bind_all(const imt::ImtSurface& surface, const crms::Lattice& lattice) {
  require(lattice.geometry().dims == geometry_.dims,
          "coupler: the lattice differs from the one the coupler was made for");
  RebindReport report;
  report.full_rebind = true;
  ensure_capacity(surface.vertex_capacity());
  slot_count_ = surface.vertex_slot_count();
  std::fill(head_.begin(), head_.end(), -1);
  std::fill(next_.begin(), next_.end(), -1);
  std::fill(prev_.begin(), prev_.end(), -1);
  for (auto& b : bindings_) b = VertexBinding{};
  std::fill(sources_.begin(), sources_.end(), 0u);
  std::fill(orphan_.begin(), orphan_.end(), std::uint8_t{0});
  bound_count_ = 0;
  std::vector<std::uint32_t> slots;
  slots.reserve(surface.live_vertex_count());
  for (std::uint32_t s = 1; s < slot_count_; ++s)
    if (surface.vertex_live(s)) slots.push_back(s);
  bind_slots(surface, lattice, slots, report, true);
  report.from_changes = report.rebound;
  pending_upload_.clear();
  device_stale_ = true;
  return report;
}

RebindReport Coupler::apply_changes(const imt::ImtSurface& surface,
                                    const imt::SurfaceChanges& changes,
                                    const crms::Lattice& lattice,
                                    const std::vector<std::int64_t>& deleted_nodes,
                                    const std::vector<crms::SpringRef>& broken_springs) {
  if (changes.reallocated || surface.vertex_capacity() > capacity_)
    return bind_all(surface, lattice);
  RebindReport report;
  slot_count_ = surface.vertex_slot_count();
  for (std::uint32_t s : changes.vertices_freed) {
    unlink(s);
    bindings_[s] = VertexBinding{};
    sources_[s] = 0;
    orphan_[s] = 0;
    pending_upload_.push_back(s);
    ++report.unbound;
  }

  std::vector<std::uint32_t> slots;
  slots.reserve(changes.vertices_added.size() + changes.vertices_modified.size());
  slots.insert(slots.end(), changes.vertices_added.begin(), changes.vertices_added.end());
  slots.insert(slots.end(), changes.vertices_modified.begin(), changes.vertices_modified.end());
  // A new normal can change which side of a cut the vertex anchors on: re-bind those too.
  slots.insert(slots.end(), changes.vertices_normal_changed.begin(),
               changes.vertices_normal_changed.end());
  std::sort(slots.begin(), slots.end());
  slots.erase(std::unique(slots.begin(), slots.end()), slots.end());
  report.from_changes = slots.size();

  // Cubes that used a deleted node, or both ends of a broken spring, as sources.
  std::vector<std::int64_t> cells;
  auto add_cell = [&](const Int3& c) {
    for (int a = 0; a < 3; ++a) {
      const int top = geometry_.dims[a] >= 2 ? geometry_.dims[a] - 2 : 0;
      if (c[a] < 0 || c[a] > top) return;
    }
    cells.push_back(geometry_.index(c.x, c.y, c.z));
  };
  for (std::int64_t node : deleted_nodes) {
    const Int3 m = geometry_.coordinates(node);
    for (int b = 0; b < 32; ++b) {
      const Int3 o = source_offset(b);
      add_cell({m.x - o.x, m.y - o.y, m.z - o.z});
    }
  }
  for (const crms::SpringRef& spring : broken_springs) {
    const Int3 m = geometry_.coordinates(spring.node);
    const Int3 step = crms::direction_offset(spring.direction);
    for (int b = 0; b < 32; ++b) {
      const Int3 o = source_offset(b);
      const Int3 other{o.x + step.x, o.y + step.y, o.z + step.z};
      if (is_source_offset(other)) add_cell({m.x - o.x, m.y - o.y, m.z - o.z});
    }
  }
  std::sort(cells.begin(), cells.end());
  cells.erase(std::unique(cells.begin(), cells.end()), cells.end());
  report.cubes_touched = cells.size();
  const std::size_t before = slots.size();
  for (std::int64_t c : cells) slots_in_cube(c, slots);
  std::sort(slots.begin(), slots.end());
  slots.erase(std::unique(slots.begin(), slots.end()), slots.end());
  report.from_topology = slots.size() - before;

  for (std::uint32_t s : slots)
    require(surface.vertex_live(s), "coupler: change list names vertex slot " +
                                        std::to_string(s) + ", which is not live");
  bind_slots(surface, lattice, slots, report, false);
  return report;
}

void Coupler::sync_device(const crms::Solver& solver) {
  (void)solver;
  if (!device_) {
    device_ = make_coupler_device();
    device_stale_ = true;
  }
  if (device_stale_) {
    device_->reserve(capacity_);
    std::vector<std::uint32_t> all(slot_count_);
    for (std::uint32_t s = 0; s < slot_count_; ++s) all[s] = s;
    device_->upload(all.data(), all.size(), bindings_.data(), sources_.data(),
                    rest_normals_.data());
    device_stale_ = false;
  } else if (!pending_upload_.empty()) {
    std::sort(pending_upload_.begin(), pending_upload_.end());
    pending_upload_.erase(std::unique(pending_upload_.begin(), pending_upload_.end()),
                          pending_upload_.end());
    device_->upload(pending_upload_.data(), pending_upload_.size(), bindings_.data(),
                    sources_.data(), rest_normals_.data());
  }
  pending_upload_.clear();
}

void Coupler::couple(const crms::Solver& solver) {
  require(solver.lattice().geometry().dims == geometry_.dims,
          "coupler: the solver's lattice differs from the one the coupler was made for");
  const DeformedLatticeView view = deformed_lattice_view(solver);
  ++version_;
  const CouplerMode mode = options_.mode;
  if (solver.on_cuda()) {
    sync_device(solver);
    device_->couple_all(view, slot_count_, mode, dirty_scratch_);
    // Download the dirty blocks, merged into ranges.
    const auto blocks = static_cast<std::uint32_t>(dirty_scratch_.size());
    std::uint32_t b = 0;
    while (b < blocks) {
      if (!dirty_scratch_[b]) {
        ++b;
        continue;
      }
      std::uint32_t e = b;
      while (e < blocks && dirty_scratch_[e]) stamp_block(e++);
      const std::uint32_t first = b * kDirtyBlockSlots;
      const std::uint32_t last = std::min(e * kDirtyBlockSlots, slot_count_);
      if (last > first) device_->download(first, last - first, positions_.data(), normals_.data());
      b = e;
    }
    return;
  }
  const LatticeReader reader{view};
  const std::uint32_t slots = slot_count_;
  const auto blocks = static_cast<std::int64_t>((slots + kDirtyBlockSlots - 1) / kDirtyBlockSlots);
  const VertexBinding* bindings = bindings_.data();
  const std::uint32_t* sources = sources_.data();
  const Vec3f* rest_normals = rest_normals_.data();
  Vec3f* positions = positions_.data();
  Vec3f* normals = normals_.data();
#pragma omp parallel for schedule(static) if (slots > 8192)
  for (std::int64_t blk = 0; blk < blocks; ++blk) {
    const auto first = static_cast<std::uint32_t>(blk) * kDirtyBlockSlots;
    const std::uint32_t last = std::min(first + kDirtyBlockSlots, slots);
    bool changed = false;
    for (std::uint32_t s = first; s < last; ++s) {
      const VertexBinding b = bindings[s];
      if (b.cell < 0) continue;
      const CoupledVertex v = couple_vertex(reader, view, b, sources[s], rest_normals[s], mode);
      if (!(v.position == positions[s]) || !(v.normal == normals[s])) {
        positions[s] = v.position;
        normals[s] = v.normal;
        changed = true;
      }
    }
    if (changed) stamp_block(static_cast<std::uint32_t>(blk));
  }
}

void Coupler::couple_slots(const crms::Solver& solver, const std::vector<std::uint32_t>& slots) {
  if (slots.empty()) return;
  const DeformedLatticeView view = deformed_lattice_view(solver);
  ++version_;
  const CouplerMode mode = options_.mode;
  for (std::uint32_t s : slots)
    require(s < slot_count_, "coupler: slot " + std::to_string(s) + " is beyond the surface");
  if (solver.on_cuda()) {
    sync_device(solver);
    device_->couple_slots(view, slots.data(), slots.size(), mode, positions_.data(),
                          normals_.data());
    for (std::uint32_t s : slots) stamp_block(s / kDirtyBlockSlots);
    return;
  }
  const LatticeReader reader{view};
  for (std::uint32_t s : slots) {
    const VertexBinding b = bindings_[s];
    if (b.cell < 0) continue;
    const CoupledVertex v = couple_vertex(reader, view, b, sources_[s], rest_normals_[s], mode);
    positions_[s] = v.position;
    normals_[s] = v.normal;
    stamp_block(s / kDirtyBlockSlots);
  }
}

std::vector<std::pair<std::uint32_t, std::uint32_t>> Coupler::changed_ranges(
    std::uint64_t since) const {
  std::vector<std::pair<std::uint32_t, std::uint32_t>> out;
  const auto blocks = static_cast<std::uint32_t>(
      std::min<std::size_t>(block_versions_.size(),
                            (slot_count_ + kDirtyBlockSlots - 1) / kDirtyBlockSlots));
  for (std::uint32_t b = 0; b < blocks; ++b) {
    if (block_versions_[b] <= since) continue;
    const std::uint32_t first = b * kDirtyBlockSlots;
    const std::uint32_t last = std::min(first + kDirtyBlockSlots, slot_count_);
    if (!out.empty() && out.back().second == first)
      out.back().second = last;
    else
      out.emplace_back(first, last);
  }
  return out;
}

}  // namespace tsf::coupler
