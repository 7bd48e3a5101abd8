#include "tsf/coupler/coupler.h"

#include <algorithm>
#include <string>

#include "coupler_device.h"
#include "tsf/common/error.h"
#include "tsf/common/stopwatch.h"
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

void Coupler::set_page_locked_outputs(bool on) {
  if (on == options_.page_locked_outputs) return;
  if (device_) device_->release_host();
  options_.page_locked_outputs = on;
  device_stale_ = true;  // the next sync registers them again (or not)
}

void Coupler::ensure_capacity(std::uint32_t capacity) {
  if (capacity <= capacity_) return;
  if (device_) device_->release_host();  // the output arrays move: registered again at the sync
  bindings_.resize(capacity);
  sources_.resize(capacity, 0);
  orphan_.resize(capacity, 0);
  rest_normals_.resize(capacity);
  positions_.resize(capacity);
  normals_.resize(capacity);
  next_.resize(capacity, -1);
  prev_.resize(capacity, -1);
  vertex_frames_.resize(capacity);
  block_versions_.resize((capacity + kDirtyBlockSlots - 1) / kDirtyBlockSlots, 0);
  capacity_ = capacity;
  device_stale_ = true;
}

namespace {

/// Stable LSD radix sort of `keys` by their bits [first_bit, end_bit), 11-bit digits.
template <typename Key>
void radix_sort_bits(std::vector<Key>& keys, std::vector<Key>& tmp, int first_bit, int end_bit) {
  constexpr int kDigitBits = 11;
  constexpr std::size_t kBuckets = std::size_t{1} << kDigitBits;
  tmp.resize(keys.size());
  std::size_t count[kBuckets];
  for (int shift = first_bit; shift < end_bit; shift += kDigitBits) {
    std::fill(std::begin(count), std::end(count), std::size_t{0});
    for (Key k : keys) ++count[(k >> shift) & (kBuckets - 1)];
    std::size_t sum = 0;
    for (std::size_t& c : count) {
      const std::size_t n = c;
      c = sum;
      sum += n;
    }
    for (Key k : keys) tmp[count[(k >> shift) & (kBuckets - 1)]++] = k;
    keys.swap(tmp);
  }
}

/// Sorts `v` ascending and drops repeats. A cut's change lists are ~10 k slots and frames, where
/// std::sort took ~0.5 ms on the GPU machine's host for each list: the radix sort over as many
/// digits as the largest value needs (two for a few million slots) takes a tenth.
void sort_unique(std::vector<std::uint32_t>& v, std::vector<std::uint32_t>& tmp) {
  if (v.size() < 512) {
    std::sort(v.begin(), v.end());
  } else {
    const std::uint32_t largest = *std::max_element(v.begin(), v.end());
    int bits = 0;
    while (bits < 32 && (largest >> bits) != 0) ++bits;
    radix_sort_bits(v, tmp, 0, bits);
  }
  v.erase(std::unique(v.begin(), v.end()), v.end());
}

}  // namespace

void Coupler::unlink(std::uint32_t slot) {
  unlink_from(slot, bindings_[slot].cell);
}

void Coupler::unlink_from(std::uint32_t slot, std::int32_t cell) {
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

std::uint32_t Coupler::acquire_frame(std::int32_t cell, std::uint32_t sources, bool single_piece) {
  const std::uint64_t key = frame_key(cell, sources);
  if (const std::uint32_t* found = frame_index_.find(key)) {
    ++frame_refs_[*found];
    return *found;
  }
  std::uint32_t f;
  if (!free_frames_.empty()) {
    f = free_frames_.back();
    free_frames_.pop_back();
  } else {
    f = static_cast<std::uint32_t>(frames_.size());
    frames_.push_back({});
    frame_refs_.push_back(0);
    frame_corners_.push_back({});
    frame_single_.push_back(0);
  }
  frames_[f] = {cell, sources};
  frame_refs_[f] = 1;
  frame_single_[f] = single_piece ? 1 : 0;
  frame_index_[key] = f;
  if (device_) pending_frames_.push_back(f);
  return f;
}

void Coupler::release_frame(std::uint32_t f) {
  if (f == kNoFrame || f >= frames_.size() || frame_refs_[f] == 0) return;
  if (--frame_refs_[f] > 0) return;
  const CubeFrame& fr = frames_[f];
  frame_index_.erase(frame_key(fr.cell, fr.sources));
  frames_[f] = {};
  free_frames_.push_back(f);
  if (device_) pending_frames_.push_back(f);
}

void Coupler::reset_frames() {
  frames_.clear();
  frame_refs_.clear();
  free_frames_.clear();
  frame_index_.clear();
  frame_corners_.clear();
  frame_single_.clear();
  pending_frames_.clear();
  std::fill(vertex_frames_.begin(), vertex_frames_.end(), VertexFrameBinding{});
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

namespace {

/// Re-binding or coupling fewer vertices than this stays on the calling thread (an ablation
/// stroke's few hundred): a parallel region costs more than it saves there.
constexpr std::int64_t kParallelVertices = 2048;

/// Sorts keys (cell << 32 | slot) by cell, keeping the order of keys with the same cell (LSD
/// radix sort, 11-bit digits over the bits a cell index can have). With the slots ascending on
/// entry, that is the order of the keys themselves.
void sort_by_cell(std::vector<std::uint64_t>& keys, std::vector<std::uint64_t>& tmp,
                  std::int64_t cell_count) {
  int bits = 0;
  while (bits < 32 && (std::int64_t{1} << bits) < cell_count) ++bits;
  radix_sort_bits(keys, tmp, 32, 32 + bits);
}

}  // namespace

void Coupler::bind_slots(const imt::ImtSurface& surface, const crms::Lattice& lattice,
                         std::vector<std::uint32_t>& slots, RebindReport& report,
                         const std::vector<std::int64_t>& touched_cells) {
  const std::vector<Vec3f>& p = surface.positions();
  const std::vector<Vec3f>& n = surface.normals();
  const auto count = static_cast<std::int64_t>(slots.size());
  const bool parallel = count >= kParallelVertices;
  // Sort by cube (key = cell << 32 | slot) so consecutive vertices reuse the binder's per-cube
  // grouping and frames. The slots arrive ascending (both callers sort them).
  Stopwatch clock;
  std::vector<std::uint64_t>& order = scratch_order_;
  order.resize(slots.size());
#pragma omp parallel for schedule(static) if (parallel)
  for (std::int64_t i = 0; i < count; ++i) {
    const std::uint32_t s = slots[static_cast<std::size_t>(i)];
    const crms::LatticeCellLocation loc = crms::locate_rest_point(geometry_, to_double(p[s]));
    order[static_cast<std::size_t>(i)] =
        (static_cast<std::uint64_t>(geometry_.index(loc.cell.x, loc.cell.y, loc.cell.z)) << 32) | s;
  }
  sort_by_cell(order, scratch_sort_, geometry_.node_count());
  report.locate_s += clock.seconds();
  clock.restart();

  // Each vertex's new binding, by its place in `order`; the coupler's own arrays are only read
  // here, so the threads share one read-only view of them (and of the lattice), each with a
  // binder of its own for the per-cube grouping cache. Fast path: a vertex that stays in its
  // cube, bound to a frame of one piece (all alive sources connected) whose nodes this edit left
  // alone, keeps its frame — binding it afresh would give the same cell and sources; only w and
  // the normal change.
  std::vector<Rebinding>& out = scratch_rebinding_;
  out.resize(order.size());
  std::size_t orphans = 0;
#pragma omp parallel if (parallel) reduction(+ : orphans)
  {
    VertexBinder binder(lattice);
#pragma omp for schedule(static)
    for (std::int64_t i = 0; i < count; ++i) {
      const auto s = static_cast<std::uint32_t>(order[static_cast<std::size_t>(i)]);
      const auto cell = static_cast<std::int32_t>(order[static_cast<std::size_t>(i)] >> 32);
      Rebinding& r = out[static_cast<std::size_t>(i)];
      r.old_cell = bindings_[s].cell;
      const std::uint32_t f = vertex_frames_[s].frame;
      r.full = f == kNoFrame || r.old_cell != cell || !frame_single_[f] || orphan_[s] ||
               std::binary_search(touched_cells.begin(), touched_cells.end(), std::int64_t{cell});
      if (!r.full) {
        const Int3 c = geometry_.coordinates(cell);
        const Vec3d rest = geometry_.rest_position(c.x, c.y, c.z);
        r.result.binding.cell = cell;
        for (int a = 0; a < 3; ++a)
          r.result.binding.w[a] =
              static_cast<float>((static_cast<double>(p[s][a]) - rest[a]) / geometry_.spacing[a]);
        continue;
      }
      r.result = binder.bind(p[s], n[s]);
      orphans += r.result.orphan ? 1 : 0;
    }
  }
  report.bind_s += clock.seconds();
  clock.restart();
  // Links and frames, in the sorted order.
  last_rebound_.resize(order.size());
  for (std::size_t i = 0; i < order.size(); ++i) {
    const auto s = static_cast<std::uint32_t>(order[i]);
    const Rebinding& r = out[i];
    last_rebound_[i] = s;
    VertexBinding& b = bindings_[s];
    b = r.result.binding;
    rest_normals_[s] = n[s];
    if (r.full) {
      sources_[s] = r.result.sources;
      orphan_[s] = r.result.orphan ? 1 : 0;
    }
    if (r.old_cell != b.cell) {
      unlink_from(s, r.old_cell);
      link(s);
    }
    VertexFrameBinding& vf = vertex_frames_[s];
    const std::uint32_t f = vf.frame;
    if (r.full &&
        (f == kNoFrame || frames_[f].cell != b.cell || frames_[f].sources != sources_[s])) {
      release_frame(f);
      vf.frame = acquire_frame(b.cell, sources_[s], r.result.single_piece);
    }
    vf.w[0] = b.w[0];
    vf.w[1] = b.w[1];
    vf.w[2] = b.w[2];
    if (device_) pending_upload_.push_back(s);
  }
  report.link_s += clock.seconds();
  report.rebound += order.size();
  report.orphans += orphans;
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
  reset_frames();
  std::vector<std::uint32_t> slots;
  slots.reserve(surface.live_vertex_count());
  for (std::uint32_t s = 1; s < slot_count_; ++s)
    if (surface.vertex_live(s)) slots.push_back(s);
  bind_slots(surface, lattice, slots, report, {});
  report.from_changes = report.rebound;
  pending_upload_.clear();
  pending_frames_.clear();
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
  const Stopwatch clock;
  slot_count_ = surface.vertex_slot_count();
  for (std::uint32_t s : changes.vertices_freed) {
    unlink(s);
    release_frame(vertex_frames_[s].frame);
    vertex_frames_[s] = {};
    bindings_[s] = VertexBinding{};
    sources_[s] = 0;
    orphan_[s] = 0;
    if (device_) pending_upload_.push_back(s);
    ++report.unbound;
  }

  std::vector<std::uint32_t> slots;
  slots.reserve(changes.vertices_added.size() + changes.vertices_modified.size());
  slots.insert(slots.end(), changes.vertices_added.begin(), changes.vertices_added.end());
  slots.insert(slots.end(), changes.vertices_modified.begin(), changes.vertices_modified.end());
  // A new normal can change which side of a cut the vertex anchors on: re-bind those too.
  slots.insert(slots.end(), changes.vertices_normal_changed.begin(),
               changes.vertices_normal_changed.end());
  sort_unique(slots, scratch_slots_);
  report.from_changes = slots.size();

  // Cubes that used a deleted node, or both ends of a broken spring, as sources. Each cube is
  // marked once (a cut's deleted nodes and broken springs name ~10 k cubes, ~1 k distinct): only
  // the distinct ones are sorted.
  std::vector<std::int64_t> cells;
  cell_marks_.resize(static_cast<std::size_t>(geometry_.node_count()), 0);
  auto add_cell = [&](const Int3& c) {
    for (int a = 0; a < 3; ++a) {
      const int top = geometry_.dims[a] >= 2 ? geometry_.dims[a] - 2 : 0;
      if (c[a] < 0 || c[a] > top) return;
    }
    const std::int64_t cell = geometry_.index(c.x, c.y, c.z);
    std::uint8_t& mark = cell_marks_[static_cast<std::size_t>(cell)];
    if (mark) return;
    mark = 1;
    cells.push_back(cell);
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
  for (std::int64_t c : cells) cell_marks_[static_cast<std::size_t>(c)] = 0;
  std::sort(cells.begin(), cells.end());
  report.cubes_touched = cells.size();
  const std::size_t before = slots.size();
  for (std::int64_t c : cells) slots_in_cube(c, slots);
  if (slots.size() > before) sort_unique(slots, scratch_slots_);
  report.from_topology = slots.size() - before;

  for (std::uint32_t s : slots)
    if (!surface.vertex_live(s))
      throw Error("coupler: change list names vertex slot " + std::to_string(s) +
                  ", which is not live");
  report.collect_s = clock.seconds();
  bind_slots(surface, lattice, slots, report, cells);
  return report;
}

void Coupler::sync_device(const crms::Solver& solver) {
  (void)solver;
  if (!device_) {
    device_ = make_coupler_device();
    device_stale_ = true;
  }
  const auto frame_slots = static_cast<std::uint32_t>(frames_.size());
  if (device_stale_ || frame_slots > device_frame_capacity_) {
    device_frame_capacity_ = std::max<std::uint32_t>(1024, frame_slots + frame_slots / 2);
    device_->reserve(capacity_, device_frame_capacity_);
    std::vector<std::uint32_t> all(slot_count_);
    for (std::uint32_t s = 0; s < slot_count_; ++s) all[s] = s;
    device_->upload_vertices(all.data(), all.size(), vertex_frames_.data(), rest_normals_.data());
    std::vector<std::uint32_t> frames(frame_slots);
    for (std::uint32_t f = 0; f < frame_slots; ++f) frames[f] = f;
    device_->upload_frames(frames.data(), frames.size(), frames_.data());
    if (options_.page_locked_outputs)
      device_->register_host(positions_.data(), normals_.data(), capacity_);
    device_stale_ = false;
  } else {
    if (!pending_frames_.empty()) {
      sort_unique(pending_frames_, scratch_slots_);
      device_->upload_frames(pending_frames_.data(), pending_frames_.size(), frames_.data());
    }
    if (!pending_upload_.empty()) {
      sort_unique(pending_upload_, scratch_slots_);
      device_->upload_vertices(pending_upload_.data(), pending_upload_.size(),
                               vertex_frames_.data(), rest_normals_.data());
    }
  }
  pending_upload_.clear();
  pending_frames_.clear();
}

void Coupler::couple(const crms::Solver& solver) {
  require(solver.lattice().geometry().dims == geometry_.dims,
          "coupler: the solver's lattice differs from the one the coupler was made for");
  const DeformedLatticeView view = deformed_lattice_view(solver);
  ++version_;
  const CouplerMode mode = options_.mode;
  if (solver.on_cuda()) {
    sync_device(solver);
    device_->couple_all(view, static_cast<std::uint32_t>(frames_.size()), slot_count_, mode,
                        dirty_scratch_);
    // Download the dirty blocks, merged into ranges, in one batch of copies.
    const auto blocks = static_cast<std::uint32_t>(dirty_scratch_.size());
    download_ranges_.clear();
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
      if (last > first) download_ranges_.emplace_back(first, last);
      b = e;
    }
    device_->download_ranges(download_ranges_, positions_.data(), normals_.data());
    return;
  }
  const LatticeReader reader{view};
  // Pass 1: every frame in use.
  const auto frames = static_cast<std::int64_t>(frames_.size());
  const CubeFrame* table = frames_.data();
  const std::uint32_t* refs = frame_refs_.data();
  FrameCorners* corners = frame_corners_.data();
#pragma omp parallel for schedule(static) if (frames > 4096)
  for (std::int64_t f = 0; f < frames; ++f)
    if (refs[f] > 0) corners[f] = resolve_frame(reader, view, table[f], mode);
  // Pass 2: every vertex from its frame, block by block (a block's stamp is written by the one
  // thread that owns the block).
  const std::uint32_t slots = slot_count_;
  const auto blocks = static_cast<std::int64_t>((slots + kDirtyBlockSlots - 1) / kDirtyBlockSlots);
  const VertexFrameBinding* vf = vertex_frames_.data();
  const Vec3f* rest_normals = rest_normals_.data();
  Vec3f* positions = positions_.data();
  Vec3f* normals = normals_.data();
#pragma omp parallel for schedule(static) if (slots > 16384)
  for (std::int64_t blk = 0; blk < blocks; ++blk) {
    const auto first = static_cast<std::uint32_t>(blk) * kDirtyBlockSlots;
    const std::uint32_t last = std::min(first + kDirtyBlockSlots, slots);
    bool changed = false;
    for (std::uint32_t s = first; s < last; ++s) {
      const VertexFrameBinding b = vf[s];
      if (b.frame == kNoFrame) continue;
      const CoupledVertex v =
          couple_from_frame(corners[b.frame], b.w, view.spacing, rest_normals[s], mode);
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
  last_couple_timing_ = {};
  if (slots.empty()) return;
  Stopwatch clock;
  auto lap = [&clock](double& into) {
    into = clock.seconds();
    clock.restart();
  };
  const DeformedLatticeView view = deformed_lattice_view(solver);
  ++version_;
  const CouplerMode mode = options_.mode;
  scratch_frames_.clear();
  for (std::uint32_t s : slots) {
    if (s >= slot_count_)
      throw Error("coupler: slot " + std::to_string(s) + " is beyond the surface");
    if (vertex_frames_[s].frame != kNoFrame) scratch_frames_.push_back(vertex_frames_[s].frame);
  }
  sort_unique(scratch_frames_, scratch_slots_);
  if (solver.on_cuda()) {
    lap(last_couple_timing_.prepare_s);
    sync_device(solver);
    lap(last_couple_timing_.upload_s);
    device_->couple_slots(view, scratch_frames_.data(), scratch_frames_.size(), slots.data(),
                          slots.size(), mode, positions_.data(), normals_.data());
    lap(last_couple_timing_.couple_s);
    for (std::uint32_t s : slots) stamp_block(s / kDirtyBlockSlots);
    lap(last_couple_timing_.stamp_s);
    return;
  }
  lap(last_couple_timing_.prepare_s);
  const LatticeReader reader{view};
  // A cut's thousands of vertices on the threads (distinct frames, distinct slots); a stroke's
  // few hundred on the calling thread.
  const bool parallel = static_cast<std::int64_t>(slots.size()) >= kParallelVertices;
  const auto frames = static_cast<std::int64_t>(scratch_frames_.size());
#pragma omp parallel for schedule(static) if (parallel)
  for (std::int64_t i = 0; i < frames; ++i) {
    const std::uint32_t f = scratch_frames_[static_cast<std::size_t>(i)];
    frame_corners_[f] = resolve_frame(reader, view, frames_[f], mode);
  }
  const auto count = static_cast<std::int64_t>(slots.size());
#pragma omp parallel for schedule(static) if (parallel)
  for (std::int64_t i = 0; i < count; ++i) {
    const std::uint32_t s = slots[static_cast<std::size_t>(i)];
    const VertexFrameBinding b = vertex_frames_[s];
    if (b.frame == kNoFrame) continue;
    const CoupledVertex v =
        couple_from_frame(frame_corners_[b.frame], b.w, view.spacing, rest_normals_[s], mode);
    positions_[s] = v.position;
    normals_[s] = v.normal;
  }
  lap(last_couple_timing_.couple_s);
  for (std::uint32_t s : slots)
    if (vertex_frames_[s].frame != kNoFrame) stamp_block(s / kDirtyBlockSlots);
  lap(last_couple_timing_.stamp_s);
}

std::vector<std::pair<std::uint32_t, std::uint32_t>> Coupler::changed_ranges(
    std::uint64_t since) const {
  std::vector<std::pair<std::uint32_t, std::uint32_t>> out;
  const auto blocks = static_cast<std::uint32_t>(std::min<std::size_t>(
      block_versions_.size(), (slot_count_ + kDirtyBlockSlots - 1) / kDirtyBlockSlots));
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
