// CPU backend: the row loops of cpu_kernels.h in OpenMP over lattice rows or tiles.
//
// Per-node evaluation (the gather form, and ForceEvaluation::kPerNode): rows (fixed j, k) are
// distributed over threads, each row one SIMD loop. Shared evaluation of the symmetric form: the
// lattice is cut into tiles of rows × z-slabs (one z-slab per thread, rows sized so that a
// thread's ring of terms stays in its core's cache) and each thread marches its tiles
// (cpu_kernels.h).
//
// The kernels are compiled for several instruction sets (cpu_kernels_<isa>.cpp); the backend takes
// the widest the processor supports, or the one SolverConfig::cpu_instruction_set names.
#include <omp.h>

#include <algorithm>
#include <array>
#include <climits>
#include <memory>
#include <optional>
#include <string>

#include "cpu_kernels.h"
#include "solver_backend.h"
#include "tsf/common/error.h"
#include "tsf/crms/effects.h"
#include "tsf/crms/node_energy.h"
#include "tsf/crms/node_force.h"
#include "tsf/crms/stencil.h"

namespace tsf::crms {
namespace {

/// Below this many nodes a step runs on one thread: a fork/join costs more than it saves (and
/// far more when the cores are shared with other work).
constexpr std::int64_t kParallelNodes = 8192;

/// Floats of one thread's term ring the tile rows are sized for: 3 planes × 21 floats × rows ×
/// nx ≈ 1.5 MB, the core's L2 and a slice of L3 (the ring is streamed, so L3 hits are cheap).
constexpr std::size_t kRingBudgetFloats = std::size_t{384} << 10;

bool processor_has(CpuInstructionSet isa) {
#if defined(__x86_64__) && defined(__GNUC__)
  switch (isa) {
    case CpuInstructionSet::kAuto:
    case CpuInstructionSet::kBaseline:
      return true;
    case CpuInstructionSet::kAvx2:
      return __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
    case CpuInstructionSet::kAvx512:
      return __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512vl") &&
             __builtin_cpu_supports("avx512bw") && __builtin_cpu_supports("avx512dq") &&
             __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
  }
  return false;
#else
  return isa == CpuInstructionSet::kAuto || isa == CpuInstructionSet::kBaseline;
#endif
}

cpu::RowKernels row_kernels(CpuInstructionSet isa, unsigned set) {
  switch (isa) {
    case CpuInstructionSet::kAvx512:
      return cpu::row_kernels_avx512(set);
    case CpuInstructionSet::kAvx2:
      return cpu::row_kernels_avx2(set);
    default:
      return cpu::row_kernels_baseline(set);
  }
}

/// The instruction set the kernels run with: the requested one (an error when the processor or
/// this build lacks it) or, for kAuto, the widest available.
CpuInstructionSet resolve_instruction_set(CpuInstructionSet requested) {
  auto usable = [](CpuInstructionSet isa) {
    return processor_has(isa) && row_kernels(isa, 0).step_row_per_node != nullptr;
  };
  if (requested == CpuInstructionSet::kAuto) {
    for (CpuInstructionSet isa : {CpuInstructionSet::kAvx512, CpuInstructionSet::kAvx2})
      if (usable(isa)) return isa;
    return CpuInstructionSet::kBaseline;
  }
  require(usable(requested), std::string("cpu_instruction_set ") + to_string(requested) +
                                 " is not supported by this processor or build");
  return requested;
}

class CpuBackend final : public SolverBackend {
 public:
  CpuBackend(const LatticeGeometry& g, const BackendOptions& options)
      : geometry_(g),
        count_(g.node_count()),
        evaluation_(options.evaluation),
        isa_(resolve_instruction_set(options.cpu_instruction_set)) {
    for (auto& buffer : state_)
      for (auto& component : buffer) component.assign(static_cast<std::size_t>(count_), 0.0f);
    // Snapshot storage is allocated on the first request (most runs never ask).
    snapshots_ = std::make_unique<SnapshotBuffer>(nullptr, nullptr, count_);
    plan_tiles(options.cpu_tile_rows);
  }

  std::string name() const override {
    return "cpu (OpenMP, " + std::to_string(omp_get_max_threads()) + " threads, " +
           to_string(isa_) + ")";
  }

  void upload_lattice(const std::vector<std::uint8_t>& flags, const std::vector<float>& inv_mass,
                      const std::vector<MaterialBlend>& material) override {
    flags_ = flags;
    inv_mass_ = inv_mass;
    material_index_.resize(material.size());
    material_weight_.resize(material.size());
    for (std::size_t n = 0; n < material.size(); ++n) {
      material_index_[n] = material[n].index;
      material_weight_[n] = material[n].weight;
    }
  }
  void update_materials(const std::vector<std::int64_t>& nodes,
                        const std::vector<MaterialBlend>& blends) override {
    for (std::size_t i = 0; i < nodes.size(); ++i) {
      material_index_[nodes[i]] = blends[i].index;
      material_weight_[nodes[i]] = blends[i].weight;
    }
  }
  void update_flags(const std::vector<std::int64_t>& nodes,
                    const std::vector<std::uint8_t>& flags) override {
    for (std::size_t i = 0; i < nodes.size(); ++i) flags_[nodes[i]] = flags[i];
  }
  void enable_external_forces() override {
    for (auto& c : external_force_)
      if (c.empty()) c.assign(static_cast<std::size_t>(count_), 0.0f);
  }
  void set_external_forces(const std::vector<std::int64_t>& nodes,
                           const std::vector<Vec3f>& forces) override {
    for (std::size_t i = 0; i < nodes.size(); ++i)
      for (int a = 0; a < 3; ++a) external_force_[a][nodes[i]] = forces[i][a];
  }
  void clear_external_forces() override {
    for (auto& c : external_force_) std::fill(c.begin(), c.end(), 0.0f);
  }

  void write_nodes(const std::vector<std::int64_t>& nodes, const std::vector<Vec3f>& u,
                   const std::vector<Vec3f>& v) override {
    auto& s = state_[current_];
    for (std::size_t i = 0; i < nodes.size(); ++i)
      for (int a = 0; a < 3; ++a) {
        s[a][nodes[i]] = u[i][a];
        s[3 + a][nodes[i]] = v[i][a];
      }
  }
  void write_state(const std::vector<Vec3f>& u, const std::vector<Vec3f>& v) override {
    auto& s = state_[current_];
    for (std::int64_t n = 0; n < count_; ++n)
      for (int a = 0; a < 3; ++a) {
        s[a][n] = u[n][a];
        s[3 + a][n] = v[n][a];
      }
  }
  void read_state(std::vector<Vec3f>* u, std::vector<Vec3f>* v) override {
    const auto& s = state_[current_];
    if (u) u->resize(static_cast<std::size_t>(count_));
    if (v) v->resize(static_cast<std::size_t>(count_));
    for (std::int64_t n = 0; n < count_; ++n) {
      if (u) (*u)[n] = {s[0][n], s[1][n], s[2][n]};
      if (v) (*v)[n] = {s[3][n], s[4][n], s[5][n]};
    }
  }

  void step(int n, const StepParameters& p, unsigned features) override {
    require_compiled_feature_set(features);
    const cpu::RowKernels kernels = row_kernels(isa_, features);
    const bool shared = evaluation_ == ForceEvaluation::kShared && kernels.march_tile != nullptr;
    for (int s = 0; s < n; ++s) {
      if (hit_) {  // halted: the state stays as it was after the failing step
        ++steps_started_;
        continue;
      }
      const std::int64_t bad = shared ? run_step_shared(kernels, p) : run_step_per_node(kernels, p);
      if (bad != LLONG_MAX) hit_ = GuardHit{bad, steps_started_};
      current_ = 1 - current_;
      ++steps_started_;
    }
  }
  std::optional<GuardHit> synchronize() override { return hit_; }
  void reset_guard() override { hit_.reset(); }

  EnergySums energy(const StepParameters& p, unsigned features) override {
    return dispatch_features(features, [&](auto f) {
      constexpr unsigned F = decltype(f)::value;
      const LatticeView lat = lattice_view();
      const ConstStateView st = state_view();
      double kinetic = 0, elastic = 0, gravitational = 0;
#pragma omp parallel for schedule(static) reduction(+ : kinetic, elastic, gravitational) \
    if (count_ >= kParallelNodes)
      for (std::int64_t n = 0; n < count_; ++n) {
        const Int3 c = geometry_.coordinates(n);
        const IndexedStencil s{lat, st, n, c.x, c.y, c.z};
        const NodeEnergy e = node_energy<F>(s, lat.rest_length, p);
        kinetic += e.kinetic;
        elastic += e.elastic;
        gravitational += e.gravitational;
      }
      return EnergySums{kinetic, elastic, gravitational};
    });
  }

  void spring_forces(const StepParameters& p, unsigned features,
                     std::vector<Vec3f>& forces) override {
    forces.assign(static_cast<std::size_t>(count_), Vec3f{0, 0, 0});
    dispatch_features(features, [&](auto f) {
      constexpr unsigned F = decltype(f)::value;
      const LatticeView lat = lattice_view();
      const ConstStateView st = state_view();
#pragma omp parallel for schedule(static) if (count_ >= kParallelNodes)
      for (std::int64_t n = 0; n < count_; ++n) {
        if (!(flags_[n] & kAliveBit)) continue;
        const Int3 c = geometry_.coordinates(n);
        const IndexedStencil s{lat, st, n, c.x, c.y, c.z};
        forces[n] = spring_force<F>(s, lat.rest_length, p.palette);
      }
    });
  }

  LatticeView lattice_view() const override {
    LatticeView l;
    l.dims = geometry_.dims;
    l.count = count_;
    l.stride_y = geometry_.dims.x;
    l.stride_z = static_cast<std::int64_t>(geometry_.dims.x) * geometry_.dims.y;
    for (int a = 0; a < 3; ++a) l.rest_length[a] = static_cast<float>(geometry_.spacing[a]);
    l.flags = flags_.data();
    l.inv_mass = inv_mass_.data();
    l.material_index = material_index_.empty() ? nullptr : material_index_.data();
    l.material_weight = material_weight_.empty() ? nullptr : material_weight_.data();
    for (int a = 0; a < 3; ++a)
      l.external_force[a] = external_force_[a].empty() ? nullptr : external_force_[a].data();
    return l;
  }
  StateView state_view() const override {
    return buffer_view(current_);
  }

  void request_snapshot(std::int64_t step) override {
    if (!snapshots_->attached()) {
      for (auto& s : snapshot_storage_) s.assign(static_cast<std::size_t>(count_) * 3, 0.0f);
      snapshots_->attach(snapshot_storage_[0].data(), snapshot_storage_[1].data());
    }
    float* dst = snapshots_->back();
    const auto& s = state_[current_];
    const LatticeGeometry& g = geometry_;
#pragma omp parallel for schedule(static)
    for (std::int64_t n = 0; n < count_; ++n) {
      const Int3 c = g.coordinates(n);
      const Vec3f x =
          node_position(g.origin, g.spacing, c.x, c.y, c.z, {s[0][n], s[1][n], s[2][n]});
      dst[3 * n + 0] = x.x;
      dst[3 * n + 1] = x.y;
      dst[3 * n + 2] = x.z;
    }
    snapshots_->publish(step);
  }
  void poll_snapshot() override {}
  const SnapshotBuffer& snapshots() const override {
    return *snapshots_;
  }

  double bytes_per_node() const override {
    double b = 2 * 6 * sizeof(float) + sizeof(std::uint8_t) + sizeof(float);
    if (!material_index_.empty()) b += 2 * sizeof(std::uint32_t);
    if (!external_force_[0].empty()) b += 3 * sizeof(float);
    return b;
  }

 private:
  StateView buffer_view(int which) const {
    StateView v;
    auto& s = const_cast<std::array<std::vector<float>, 6>&>(state_[which]);
    for (int a = 0; a < 3; ++a) {
      v.u[a] = s[a].data();
      v.v[a] = s[3 + a].data();
    }
    return v;
  }

  cpu::StepContext context(const StepParameters& p) const {
    cpu::StepContext c;
    c.lattice = lattice_view();
    c.in = buffer_view(current_);
    c.out = buffer_view(1 - current_);
    c.parameters = p;
    return c;
  }

  int threads_for_step() const {
    return count_ >= kParallelNodes ? omp_get_max_threads() : 1;
  }

  /// One step from state_[current_] into the other buffer, every node from its whole stencil;
  /// returns the first non-finite node or LLONG_MAX.
  std::int64_t run_step_per_node(const cpu::RowKernels& kernels, const StepParameters& p) {
    const cpu::StepContext c = context(p);
    prepare_scratch(threads_for_step(), false);
    const int ny = geometry_.dims.y;
    const std::int64_t rows = static_cast<std::int64_t>(ny) * geometry_.dims.z;
    std::int64_t first_bad = LLONG_MAX;
#pragma omp parallel for schedule(static) reduction(min : first_bad) num_threads(threads_for_step())
    for (std::int64_t row = 0; row < rows; ++row) {
      const int j = static_cast<int>(row % ny), k = static_cast<int>(row / ny);
      first_bad =
          std::min(first_bad, kernels.step_row_per_node(c, j, k, scratch_[omp_get_thread_num()]));
    }
    return first_bad;
  }

  /// Per-thread scratch (row scratch always, term rings for the shared evaluation), allocated
  /// and zeroed on first use.
  void prepare_scratch(int threads, bool rings) {
    const int nx = geometry_.dims.x;
    if (static_cast<int>(scratch_.size()) < threads) {
      scratch_storage_.resize(static_cast<std::size_t>(threads));
      scratch_.resize(static_cast<std::size_t>(threads));
      rings_.resize(static_cast<std::size_t>(threads));
    }
    for (int t = 0; t < threads; ++t) {
      if (scratch_storage_[t].empty()) {
        scratch_storage_[t].assign(cpu::RowScratch::ints(nx), 0);
        scratch_[t] = cpu::RowScratch::over(scratch_storage_[t].data(), nx);
      }
      if (rings && rings_[t].empty())
        rings_[t].assign(cpu::TermRing::floats(tile_rows_ + 2, nx), 0.0f);
    }
  }

  /// Tiles of the shared evaluation: y-tiles of `rows` rows (0: sized for the cache) × one z-slab
  /// per thread (slabs of at least 4 planes: the slab ends cost 2/3 of a plane each).
  void plan_tiles(int rows) {
    const int nx = geometry_.dims.x, ny = geometry_.dims.y, nz = geometry_.dims.z;
    if (rows == 0) {
      const std::size_t per_row = cpu::TermRing::floats(1, nx);
      rows = static_cast<int>(std::max<std::size_t>(kRingBudgetFloats / per_row, 3)) - 2;
    }
    rows = std::clamp(rows, 1, ny);
    const int y_tiles = (ny + rows - 1) / rows;
    rows = (ny + y_tiles - 1) / y_tiles;
    const int slabs = std::clamp(nz / 4, 1, std::max(1, omp_get_max_threads()));
    tiles_.clear();
    for (int s = 0; s < slabs; ++s) {
      const int k0 = static_cast<int>(static_cast<std::int64_t>(nz) * s / slabs);
      const int k1 = static_cast<int>(static_cast<std::int64_t>(nz) * (s + 1) / slabs);
      for (int t = 0; t < y_tiles; ++t) {
        cpu::Tile tile;
        tile.j0 = t * rows;
        tile.j1 = std::min(ny, (t + 1) * rows);
        tile.k0 = k0;
        tile.k1 = k1;
        if (tile.j0 < tile.j1 && k0 < k1) tiles_.push_back(tile);
      }
    }
    tile_rows_ = rows;
  }

  /// One step with the shared evaluation (symmetric form); returns the first non-finite node or
  /// LLONG_MAX.
  std::int64_t run_step_shared(const cpu::RowKernels& kernels, const StepParameters& p) {
    const cpu::StepContext c = context(p);
    const int threads = threads_for_step();
    const int nx = geometry_.dims.x;
    prepare_scratch(threads, true);
    const auto tiles = static_cast<std::int64_t>(tiles_.size());
    std::int64_t first_bad = LLONG_MAX;
#pragma omp parallel for schedule(static) reduction(min : first_bad) num_threads(threads)
    for (std::int64_t t = 0; t < tiles; ++t) {
      const int me = omp_get_thread_num();
      cpu::TermRing ring;
      ring.data = rings_[me].data();
      ring.rows = tile_rows_ + 2;
      ring.stride = nx + 2;
      first_bad = std::min(first_bad, kernels.march_tile(c, ring, tiles_[t], scratch_[me]));
    }
    return first_bad;
  }

  LatticeGeometry geometry_;
  std::int64_t count_;
  ForceEvaluation evaluation_;
  CpuInstructionSet isa_;
  std::vector<cpu::Tile> tiles_;
  int tile_rows_ = 1;
  std::vector<std::vector<float>> rings_;  // per thread, zeroed once
  std::vector<std::vector<std::int32_t>> scratch_storage_;
  std::vector<cpu::RowScratch> scratch_;
  std::array<std::array<std::vector<float>, 6>, 2> state_;  // [buffer][ux,uy,uz,vx,vy,vz]
  int current_ = 0;
  std::vector<std::uint8_t> flags_;
  std::vector<std::uint32_t> material_index_, material_weight_;
  std::vector<float> inv_mass_;
  std::array<std::vector<float>, 3> external_force_;
  std::int64_t steps_started_ = 0;
  std::optional<GuardHit> hit_;
  std::array<std::vector<float>, 2> snapshot_storage_;
  std::unique_ptr<SnapshotBuffer> snapshots_;
};

}  // namespace

std::unique_ptr<SolverBackend> make_cpu_backend(const LatticeGeometry& geometry,
                                                const BackendOptions& options) {
  return std::make_unique<CpuBackend>(geometry, options);
}

}  // namespace tsf::crms
