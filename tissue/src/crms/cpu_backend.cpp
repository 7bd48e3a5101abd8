// CPU backend: the per-node step of node_update.h in an OpenMP loop over lattice rows.
//
// Rows (fixed j, k) are distributed over threads; within a row the interior nodes run in a SIMD
// loop (`omp simd`) over x, reading neighbours through nine row pointers (rows outside the lattice
// alias the centre row; link bits zero their contribution), and the two row ends go through the
// bounds-checked IndexedStencil. The row function is flattened so that the whole per-node
// physics is inlined into the SIMD loop (a per-function `target("avx2")` clone was tried: GCC
// then refuses to inline the default-target physics into it and calls it per node, 2× slower).
//
// No errno from sqrt: this translation unit is compiled as if with -fno-math-errno (the pragma
// must precede every include so that all functions defined here agree), which lets sqrtf become a
// vector instruction. The physics never takes the square root of a negative number (arguments
// are squared lengths and clamped 1 − c²).
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC optimize("no-math-errno")
#endif

#include <omp.h>

#include <algorithm>
#include <array>
#include <climits>
#include <memory>
#include <optional>
#include <string>

#include "solver_backend.h"
#include "tsf/common/error.h"
#include "tsf/crms/effects.h"
#include "tsf/crms/node_update.h"
#include "tsf/crms/stencil.h"

#if defined(__GNUC__)
#define TSF_FLATTEN __attribute__((flatten))
#else
#define TSF_FLATTEN
#endif

namespace tsf::crms {
namespace {

/// Below this many nodes a step runs on one thread: a fork/join costs more than it saves (and
/// far more when the cores are shared with other work).
constexpr std::int64_t kParallelNodes = 8192;

/// Row pointers of the 3×3 block of rows around (j, k): index (dy+1) + 3·(dz+1).
struct RowBlock {
  const float* u[3][9];
  const float* v[3][9];
  const std::uint8_t* flags[9];
  const std::uint8_t* material[9];
  const float* inv_mass;
  const float* external_force[3];
};

/// Stencil accessor for interior x positions of a row (x ± 1 always inside).
struct RowStencil {
  using Scalar = float;
  const RowBlock& b;
  int i;

  static constexpr int row(int slot) {
    return (slot_offset(slot, 1) + 1) + 3 * (slot_offset(slot, 2) + 1);
  }
  Vec3f u(int slot) const {
    const int r = row(slot), x = i + slot_offset(slot, 0);
    return {b.u[0][r][x], b.u[1][r][x], b.u[2][r][x]};
  }
  Vec3f v(int slot) const {
    const int r = row(slot), x = i + slot_offset(slot, 0);
    return {b.v[0][r][x], b.v[1][r][x], b.v[2][r][x]};
  }
  unsigned flags(int slot) const { return b.flags[row(slot)][i + slot_offset(slot, 0)]; }
  int material(int slot) const { return b.material[row(slot)][i + slot_offset(slot, 0)]; }
  float inv_mass() const { return b.inv_mass[i]; }
  Vec3f external_force() const {
    return {b.external_force[0][i], b.external_force[1][i], b.external_force[2][i]};
  }
};

struct RowOutput {
  float* u[3];
  float* v[3];
};

template <unsigned F>
inline __attribute__((always_inline)) bool step_row_interior(const RowBlock& b,
                                                             const RowOutput& out,
                                                             const float* rest_length,
                                                             const StepParameters& p, int i0,
                                                             int i1) {
  int bad = 0;
#pragma omp simd reduction(| : bad)
  for (int i = i0; i < i1; ++i) {
    const RowStencil st{b, i};
    const NodeStepResult r = step_node<F>(st, rest_length, p);
    out.u[0][i] = r.u.x;
    out.u[1][i] = r.u.y;
    out.u[2][i] = r.u.z;
    out.v[0][i] = r.v.x;
    out.v[1][i] = r.v.y;
    out.v[2][i] = r.v.z;
    bad |= r.finite ? 0 : 1;
  }
  return bad != 0;
}

template <unsigned F>
TSF_FLATTEN bool step_row_simd(const RowBlock& b, const RowOutput& out, const float* rest_length,
                               const StepParameters& p, int i0, int i1) {
  return step_row_interior<F>(b, out, rest_length, p, i0, i1);
}

class CpuBackend final : public SolverBackend {
 public:
  explicit CpuBackend(const LatticeGeometry& g) : geometry_(g), count_(g.node_count()) {
    for (auto& buffer : state_)
      for (auto& component : buffer) component.assign(static_cast<std::size_t>(count_), 0.0f);
    // Snapshot storage is allocated on the first request (most runs never ask).
    snapshots_ = std::make_unique<SnapshotBuffer>(nullptr, nullptr, count_);
  }

  std::string name() const override {
    return "cpu (OpenMP, " + std::to_string(omp_get_max_threads()) + " threads)";
  }

  void upload_lattice(const std::vector<std::uint8_t>& flags, const std::vector<float>& inv_mass,
                      const std::vector<std::uint8_t>& material) override {
    flags_ = flags;
    inv_mass_ = inv_mass;
    material_ = material;
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
    dispatch_features(features, [&](auto f) {
      constexpr unsigned F = decltype(f)::value;
      for (int s = 0; s < n; ++s) {
        if (hit_) {  // halted: the state stays as it was after the failing step
          ++steps_started_;
          continue;
        }
        const std::int64_t bad = run_step<F>(p);
        if (bad != LLONG_MAX) hit_ = GuardHit{bad, steps_started_};
        current_ = 1 - current_;
        ++steps_started_;
      }
    });
  }
  std::optional<GuardHit> synchronize() override { return hit_; }
  void reset_guard() override { hit_.reset(); }

  EnergySums energy(const StepParameters& p, unsigned features) override {
    return dispatch_features(features, [&](auto f) {
      constexpr unsigned F = decltype(f)::value;
      const LatticeView lat = lattice_view();
      const ConstStateView st = state_view();
      const float rest[3] = {lat.rest_length[0], lat.rest_length[1], lat.rest_length[2]};
      double kinetic = 0, elastic = 0, gravitational = 0;
#pragma omp parallel for schedule(static) reduction(+ : kinetic, elastic, gravitational) \
    if (count_ >= kParallelNodes)
      for (std::int64_t n = 0; n < count_; ++n) {
        const unsigned fl = flags_[n];
        if (!(fl & kAliveBit)) continue;
        const Int3 c = geometry_.coordinates(n);
        const IndexedStencil s{lat, st, n, c.x, c.y, c.z};
        elastic += static_cast<double>(elastic_energy<F>(s, rest, p.palette));
        const double m = 1.0 / static_cast<double>(inv_mass_[n]);
        const Vec3f v = s.v(0), u = s.u(0);
        kinetic += 0.5 * m * dot(to_double(v), to_double(v));
        if (!(fl & kFixedBit)) gravitational -= m * dot(to_double(p.gravity), to_double(u));
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
    l.material = material_.empty() ? nullptr : material_.data();
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
      const Vec3d r = g.rest_position(n);
      dst[3 * n + 0] = static_cast<float>(r.x + static_cast<double>(s[0][n]));
      dst[3 * n + 1] = static_cast<float>(r.y + static_cast<double>(s[1][n]));
      dst[3 * n + 2] = static_cast<float>(r.z + static_cast<double>(s[2][n]));
    }
    snapshots_->publish(step);
  }
  void poll_snapshot() override {}
  const SnapshotBuffer& snapshots() const override {
    return *snapshots_;
  }

  double bytes_per_node() const override {
    double b = 2 * 6 * sizeof(float) + sizeof(std::uint8_t) + sizeof(float);
    if (!material_.empty()) b += 1;
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

  /// One step from state_[current_] into the other buffer; returns the first non-finite node or
  /// LLONG_MAX.
  template <unsigned F>
  std::int64_t run_step(const StepParameters& p) {
    const LatticeView lat = lattice_view();
    const ConstStateView in = buffer_view(current_);
    const StateView out = buffer_view(1 - current_);
    const int nx = geometry_.dims.x, ny = geometry_.dims.y, nz = geometry_.dims.z;
    const std::int64_t rows = static_cast<std::int64_t>(ny) * nz;
    const float rest[3] = {lat.rest_length[0], lat.rest_length[1], lat.rest_length[2]};
    std::int64_t first_bad = LLONG_MAX;
#pragma omp parallel for schedule(static) reduction(min : first_bad) if (count_ >= kParallelNodes)
    for (std::int64_t row = 0; row < rows; ++row) {
      const int j = static_cast<int>(row % ny), k = static_cast<int>(row / ny);
      const std::int64_t base = row * nx;
      RowBlock b;
      for (int dz = -1; dz <= 1; ++dz)
        for (int dy = -1; dy <= 1; ++dy) {
          const bool inside = j + dy >= 0 && j + dy < ny && k + dz >= 0 && k + dz < nz;
          const std::int64_t rb = inside ? base + dy * lat.stride_y + dz * lat.stride_z : base;
          const int r = (dy + 1) + 3 * (dz + 1);
          for (int a = 0; a < 3; ++a) {
            b.u[a][r] = in.u[a] + rb;
            b.v[a][r] = in.v[a] + rb;
          }
          b.flags[r] = lat.flags + rb;
          b.material[r] = lat.material ? lat.material + rb : nullptr;
        }
      b.inv_mass = lat.inv_mass + base;
      for (int a = 0; a < 3; ++a)
        b.external_force[a] = lat.external_force[a] ? lat.external_force[a] + base : nullptr;
      RowOutput o;
      for (int a = 0; a < 3; ++a) {
        o.u[a] = out.u[a] + base;
        o.v[a] = out.v[a] + base;
      }

      bool row_bad = false;
      // Row ends through the bounds-checked accessor.
      const int ends[2] = {0, nx - 1};
      for (int e = 0; e < (nx > 1 ? 2 : 1); ++e) {
        const int i = ends[e];
        const IndexedStencil st{lat, in, base + i, i, j, k};
        const NodeStepResult r = step_node<F>(st, rest, p);
        for (int a = 0; a < 3; ++a) {
          o.u[a][i] = r.u[a];
          o.v[a][i] = r.v[a];
        }
        row_bad |= !r.finite;
      }
      if (nx > 2) row_bad |= step_row_simd<F>(b, o, rest, p, 1, nx - 1);
      if (row_bad) {
        // Rare: find the first failing node of the row by recomputing it.
        for (int i = 0; i < nx; ++i) {
          const IndexedStencil st{lat, in, base + i, i, j, k};
          if (!step_node<F>(st, rest, p).finite) {
            first_bad = std::min(first_bad, base + i);
            break;
          }
        }
      }
    }
    return first_bad;
  }

  LatticeGeometry geometry_;
  std::int64_t count_;
  std::array<std::array<std::vector<float>, 6>, 2> state_;  // [buffer][ux,uy,uz,vx,vy,vz]
  int current_ = 0;
  std::vector<std::uint8_t> flags_, material_;
  std::vector<float> inv_mass_;
  std::array<std::vector<float>, 3> external_force_;
  std::int64_t steps_started_ = 0;
  std::optional<GuardHit> hit_;
  std::array<std::vector<float>, 2> snapshot_storage_;
  std::unique_ptr<SnapshotBuffer> snapshots_;
};

}  // namespace

std::unique_ptr<SolverBackend> make_cpu_backend(const LatticeGeometry& geometry) {
  return std::make_unique<CpuBackend>(geometry);
}

}  // namespace tsf::crms
