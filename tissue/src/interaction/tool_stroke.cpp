#include "tsf/interaction/tool_stroke.h"

#include <algorithm>
#include <cmath>
#include <memory>
#include <string>
#include <vector>

#include <omp.h>

#include "tsf/common/error.h"
#include "tsf/common/stopwatch.h"

namespace tsf::interaction {
namespace {

double min_spacing(const VolumeGeometry& g) {
  return std::min(g.spacing.x, std::min(g.spacing.y, g.spacing.z));
}

void check(const RemovalOptions& o, const char* what) {
  if (!(std::isfinite(o.strength) && o.strength >= 0.0f && o.strength <= 1.0f))
    throw Error(std::string(what) + ": strength must lie in [0,1], got " +
                std::to_string(o.strength));
  if (!std::isfinite(o.falloff_mm)) throw Error(std::string(what) + ": falloff_mm must be finite");
}

/// A blade sweep whose sub-steps visit at least this many voxels in all (a few milliseconds on
/// one thread: a cut) shares them among the threads; a short move of a small blade stays on the
/// calling thread.
constexpr std::int64_t kParallelCutVisits = std::int64_t{1} << 18;

/// Sub-steps so that no point moves more than half a voxel between samples.
int sub_steps(double travel_mm, double voxel_mm, const char* what) {
  const int steps = std::max(1, static_cast<int>(std::ceil(travel_mm / (0.5 * voxel_mm))));
  if (steps > 100000)
    throw Error(std::string(what) + ": a move of " + std::to_string(travel_mm) +
                " mm is too long for one step; split it into shorter moves");
  return steps;
}

/// One sub-step's share of a row of a blade sweep: voxels [m0, m1) of the row (m counted from the
/// sweep box's first x), their smallest distances so far in inside[m] and outside2[m]
/// (BladeDistanceMin) taking this sub-step in. Branch-free (selects) with no square root or
/// division, so it vectorises, and built for the wider vector units too (chosen when the
/// program loads): the same IEEE operations in the same order in every build (no contraction
/// into FMA: this file is compiled with -ffp-contract=off), so every build gives the same weights.
#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
__attribute__((target_clones("avx512f", "avx2", "default")))
#endif
void blade_row(const Vec3d& half_extents, const BladeRowFrame& frame, int m0, int m1,
               double* inside, double* outside2) {
  for (int m = m0; m < m1; ++m) {
    BladeDistanceMin acc{inside[m], outside2[m]};
    acc.add(half_extents, frame.at(m));
    inside[m] = acc.inside;
    outside2[m] = acc.outside2;
  }
}

}  // namespace

template <typename Weight>
VoxelBox ToolStroke::apply(VoxelVolume& volume, const VoxelBox& box, const RemovalOptions& o,
                           const Weight& weight) {
  reached_.fill(0.0);
  if (box.empty() || o.strength <= 0.0f) return {};
  float* density = volume.density_for_tracked_write();
  const std::uint8_t* labels = volume.label_data().data();
  VoxelBox changed{};
  for (int k = box.lo.z; k < box.hi.z; ++k)
    for (int j = box.lo.y; j < box.hi.y; ++j)
      for (int i = box.lo.x; i < box.hi.x; ++i) {
        const std::size_t v = volume.index(i, j, k);
        const float old = density[v];
        if (old <= 0.0f) continue;
        const float w = o.strength * weight(i, j, k);
        if (w <= 0.0f) continue;
        float& done = applied_[v];
        if (w <= done) continue;
        const float removal = o.rates[labels[v]] * (w - done);
        reached_[labels[v]] += static_cast<double>(std::min(old, w - done));
        done = w;
        const float now = std::max(0.0f, old - removal);
        if (now != old) {
          density[v] = now;
          changed.include(i, j, k);
        }
      }
  volume.mark_modified(changed);
  return changed;
}

VoxelBox ToolStroke::ablate_ball(VoxelVolume& volume, const Vec3d& from, const Vec3d& to,
                                 double radius, const RemovalOptions& o) {
  check(o, "ablate");
  require(all_finite(from) && all_finite(to) && std::isfinite(radius) && radius >= 0,
          "ablate: the ball needs finite positions and a radius >= 0 (mm)");
  const VolumeGeometry& g = volume.geometry();
  const double h = o.falloff_mm < 0 ? min_spacing(g) : o.falloff_mm;
  const CapsuleTool path{from, to, radius};
  const Vec3d lo{std::min(from.x, to.x), std::min(from.y, to.y), std::min(from.z, to.z)};
  const Vec3d hi{std::max(from.x, to.x), std::max(from.y, to.y), std::max(from.z, to.z)};
  const VoxelBox box = voxels_near_box(g, lo, hi, radius + h);
  return apply(volume, box, o, [&](int i, int j, int k) {
    return falloff_weight(
        capsule_distance(path, g.index_to_tissue({double(i), double(j), double(k)})), h);
  });
}

VoxelBox ToolStroke::ablate_wand(VoxelVolume& volume, const CapsuleTool& from,
                                 const CapsuleTool& to, const RemovalOptions& o) {
  check(o, "ablate");
  require(all_finite(from.a) && all_finite(from.b) && all_finite(to.a) && all_finite(to.b) &&
              std::isfinite(from.radius) && std::isfinite(to.radius) && from.radius >= 0 &&
              to.radius >= 0,
          "ablate: the wand needs finite ends and radii >= 0 (mm)");
  const VolumeGeometry& g = volume.geometry();
  const double voxel = min_spacing(g);
  const double h = o.falloff_mm < 0 ? voxel : o.falloff_mm;
  const int steps =
      sub_steps(std::max(length(to.a - from.a), length(to.b - from.b)), voxel, "ablate");
  std::vector<CapsuleTool> caps(static_cast<std::size_t>(steps) + 1);
  Vec3d lo{1e300, 1e300, 1e300}, hi{-1e300, -1e300, -1e300};
  double rmax = 0;
  for (int s = 0; s <= steps; ++s) {
    const double t = static_cast<double>(s) / steps;
    const CapsuleTool c{from.a + (to.a - from.a) * t, from.b + (to.b - from.b) * t,
                        from.radius + (to.radius - from.radius) * t};
    caps[static_cast<std::size_t>(s)] = c;
    for (const Vec3d& p : {c.a, c.b}) {
      lo = {std::min(lo.x, p.x), std::min(lo.y, p.y), std::min(lo.z, p.z)};
      hi = {std::max(hi.x, p.x), std::max(hi.y, p.y), std::max(hi.z, p.z)};
    }
    rmax = std::max(rmax, c.radius);
  }
  const VoxelBox box = voxels_near_box(g, lo, hi, rmax + h);
  return apply(volume, box, o, [&](int i, int j, int k) {
    const Vec3d p = g.index_to_tissue({double(i), double(j), double(k)});
    double d = 1e300;
    for (const CapsuleTool& c : caps) d = std::min(d, capsule_distance(c, p));
    return falloff_weight(d, h);
  });
}

BladeSweepPlan plan_blade_sweep(const VolumeGeometry& g, const BladeTool& blade,
                                const ToolPose& from, const ToolPose& to, const RemovalOptions& o) {
  check(o, "cut");
  const Vec3d& e = blade.half_extents;
  require(all_finite(e) && e.x >= 0 && e.y >= 0 && e.z >= 0,
          "cut: blade half extents must be finite and >= 0 (mm)");
  require(all_finite(from.position) && all_finite(to.position),
          "cut: blade poses must have finite positions");
  const double voxel = min_spacing(g);
  BladeSweepPlan plan;
  plan.blade = blade;
  plan.h = o.falloff_mm < 0 ? voxel : o.falloff_mm;
  const ToolPose a{from.position, from.orientation.normalized()};
  const ToolPose b{to.position, to.orientation.normalized()};
  const double corner = length(e);
  const int steps =
      sub_steps(length(b.position - a.position) + a.orientation.angle_to(b.orientation) * corner,
                voxel, "cut");
  // Each sub-step's box is bounded by its world-axis extent |R|·e (a thin blade's is thin), not
  // by the sphere through its corners: a 40 mm blade sweeping 70 mm visits ~60× fewer voxels.
  plan.steps.resize(static_cast<std::size_t>(steps) + 1);
  std::vector<Vec3d> reach(plan.steps.size());
  Vec3d lo{1e300, 1e300, 1e300}, hi{-1e300, -1e300, -1e300};
  for (int s = 0; s <= steps; ++s) {
    const double t = static_cast<double>(s) / steps;
    const ToolPose p{a.position + (b.position - a.position) * t,
                     Rotation::slerp(a.orientation, b.orientation, t)};
    Vec3d ext{0, 0, 0};
    for (int axis = 0; axis < 3; ++axis) {
      Vec3d v{0, 0, 0};
      v[axis] = e[axis];
      const Vec3d w = p.orientation.apply(v);
      ext += Vec3d{std::fabs(w.x), std::fabs(w.y), std::fabs(w.z)};
    }
    plan.steps[static_cast<std::size_t>(s)].pose = p;
    reach[static_cast<std::size_t>(s)] = ext;
    lo = {std::min(lo.x, p.position.x - ext.x), std::min(lo.y, p.position.y - ext.y),
          std::min(lo.z, p.position.z - ext.z)};
    hi = {std::max(hi.x, p.position.x + ext.x), std::max(hi.y, p.position.y + ext.y),
          std::max(hi.z, p.position.z + ext.z)};
  }
  plan.box = voxels_near_box(g, lo, hi, plan.h);
  for (std::size_t n = 0; n < plan.steps.size(); ++n) {
    BladeSweepStep& st = plan.steps[n];
    st.box = voxels_near_box(g, st.pose.position - reach[n], st.pose.position + reach[n], plan.h)
                 .intersected(plan.box);
    plan.visits += st.box.voxel_count();
  }
  return plan;
}

VoxelBox ToolStroke::cut_blade(VoxelVolume& volume, const BladeTool& blade, const ToolPose& from,
                               const ToolPose& to, const RemovalOptions& o, BladeSweeper* sweeper) {
  return cut_blade(volume, plan_blade_sweep(volume.geometry(), blade, from, to, o), o, sweeper);
}

VoxelBox ToolStroke::cut_blade(VoxelVolume& volume, const BladeSweepPlan& plan,
                               const RemovalOptions& o, BladeSweeper* sweeper) {
  sweep_seconds_ = 0;
  const Stopwatch clock;
  const VolumeGeometry& g = volume.geometry();
  const std::vector<BladeSweepStep>& steps = plan.steps;
  const VoxelBox& box = plan.box;
  const double h = plan.h;
  if (box.empty()) return {};
  // Largest weight over the sub-steps, per voxel of the box.
  const Int3 ext = box.extent();
  std::vector<float> weight(static_cast<std::size_t>(box.voxel_count()), 0.0f);
  auto at = [&](int i, int j, int k) -> float& {
    return weight[static_cast<std::size_t>(i - box.lo.x) +
                  static_cast<std::size_t>(ext.x) *
                      (static_cast<std::size_t>(j - box.lo.y) +
                       static_cast<std::size_t>(ext.y) * static_cast<std::size_t>(k - box.lo.z))];
  };
  if (sweeper) {
    sweeper->sweep(plan, g, weight);
    require(weight.size() == static_cast<std::size_t>(box.voxel_count()),
            "cut: the blade sweeper returned the wrong number of weights (internal)");
    sweep_seconds_ = clock.seconds();
    return apply(volume, box, o, [&](int i, int j, int k) { return at(i, j, k); });
  }
  // Every sub-step visits the voxels its box reaches (the sinus scene's cut: ~150 sub-steps of
  // ~8 k voxels, each voxel of the box visited ~60 times), keeping each voxel's smallest
  // distance; the fall-off is taken once per voxel at the end. Above kParallelCutVisits each
  // thread takes a share of the sub-steps into minima of its own, and then a share of the voxels,
  // whose minima over the threads it takes (minima do not depend on the order): one barrier.
  const std::size_t count = weight.size();
  const Vec3d& half = plan.blade.half_extents;
  const int threads = plan.visits >= kParallelCutVisits ? omp_get_max_threads() : 1;
  // Per thread, `count` inside minima then `count` squared outside minima; each thread fills its
  // own (first touch on its core).
  const std::unique_ptr<double[]> minima(new double[2 * count * static_cast<std::size_t>(threads)]);
#pragma omp parallel num_threads(threads) if (threads > 1)
  {
    const auto t = static_cast<std::size_t>(omp_get_thread_num());
    const auto share = static_cast<std::size_t>(omp_get_num_threads());
    double* inside = minima.get() + 2 * count * t;
    double* outside2 = inside + count;
    std::fill(inside, inside + count, 1.0);
    std::fill(outside2, outside2 + count, INFINITY);
    for (std::size_t n = steps.size() * t / share; n < steps.size() * (t + 1) / share; ++n) {
      const VoxelBox& sb = steps[n].box;
      for (int k = sb.lo.z; k < sb.hi.z; ++k)
        for (int j = sb.lo.y; j < sb.hi.y; ++j) {
          const BladeRowFrame frame = blade_row_frame(
              steps[n].pose, g.index_to_tissue({double(box.lo.x), double(j), double(k)}),
              g.spacing.x);
          const std::size_t row = static_cast<std::size_t>(&at(box.lo.x, j, k) - weight.data());
          blade_row(half, frame, sb.lo.x - box.lo.x, sb.hi.x - box.lo.x, inside + row,
                    outside2 + row);
        }
    }
#pragma omp barrier
#pragma omp for schedule(static)
    for (std::int64_t v = 0; v < static_cast<std::int64_t>(count); ++v) {
      const auto at_v = static_cast<std::size_t>(v);
      BladeDistanceMin nearest;
      for (std::size_t u = 0; u < share; ++u)
        nearest.merge({minima[2 * count * u + at_v], minima[2 * count * u + count + at_v]});
      const double d = nearest.distance();
      weight[at_v] = d < h ? falloff_weight(d, h) : 0.0f;
    }
  }
  sweep_seconds_ = clock.seconds();
  return apply(volume, box, o, [&](int i, int j, int k) { return at(i, j, k); });
}

}  // namespace tsf::interaction
