#include "tsf/volume/volume_edits.h"

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "tsf/common/error.h"

namespace tsf {

LabelRates LabelRates::uniform(float r) {
  LabelRates out;
  out.rate.fill(r);
  return out;
}

LabelRates LabelRates::tissue_defaults() {
  LabelRates out = uniform(1.0f);
  out.rate[kLabelCartilage] = 0.35f;
  out.rate[kLabelCancellousBone] = 0.15f;
  out.rate[kLabelCorticalBone] = 0.05f;
  for (int l = kLabelFirstOverlay; l < kLabelFirstUser; ++l) out.rate[l] = 0.8f;
  return out;
}

namespace {

double min_spacing(const VolumeGeometry& g) {
  return std::min(g.spacing.x, std::min(g.spacing.y, g.spacing.z));
}

double falloff_half_width(const VolumeGeometry& g, const RemovalOptions& o) {
  return o.falloff_mm < 0.0 ? min_spacing(g) : o.falloff_mm;
}

void check_options(const RemovalOptions& o, const char* edit) {
  require(std::isfinite(o.strength) && o.strength >= 0.0f && o.strength <= 1.0f,
          std::string(edit) + ": strength must lie in [0,1], got " + std::to_string(o.strength));
  require(std::isfinite(o.falloff_mm),
          std::string(edit) + ": falloff_mm must be finite, got " + std::to_string(o.falloff_mm));
  for (int l = 0; l < 256; ++l)
    require(std::isfinite(o.rates.rate[l]) && o.rates.rate[l] >= 0.0f && o.rates.rate[l] <= 1.0f,
            std::string(edit) + ": removal rate of label " + std::to_string(l) +
                " must lie in [0,1], got " + std::to_string(o.rates.rate[l]));
}

/// Below this many candidate voxels an edit runs on the calling thread: interactive edits are
/// small and a parallel region would cost more than it saves.
constexpr std::int64_t kParallelEditVoxels = 1 << 16;

/// The whole row of `box` (tools without a cheaper bound).
struct FullRows {
  void operator()(int, int, int&, int&) const {}
};

/// new = max(0, old − strength · rate(label) · weight(i,j,k)) over `box` (row (j,k) narrowed to
/// [i0, i1) by `rows`); returns changed voxels.
template <typename WeightFn, typename RowFn = FullRows>
VoxelBox apply_removal(VoxelVolume& volume, const VoxelBox& box, const RemovalOptions& o,
                       const WeightFn& weight, const RowFn& rows = {}) {
  if (box.empty() || o.strength <= 0.0f) return {};
  float* density = volume.density_for_tracked_write();
  const std::uint8_t* labels = volume.label_data().data();
  VoxelBox changed{};
  const bool parallel = box.voxel_count() >= kParallelEditVoxels;
#pragma omp parallel if (parallel)
  {
    VoxelBox local{};
#pragma omp for schedule(static)
    for (int k = box.lo.z; k < box.hi.z; ++k)
      for (int j = box.lo.y; j < box.hi.y; ++j) {
        int i0 = box.lo.x, i1 = box.hi.x;
        rows(j, k, i0, i1);
        for (int i = i0; i < i1; ++i) {
          const std::size_t v = volume.index(i, j, k);
          const float old = density[v];
          if (old <= 0.0f) continue;
          const float w = weight(i, j, k);
          if (w <= 0.0f) continue;
          const float removal = o.strength * o.rates[labels[v]] * w;
          const float now = std::max(0.0f, old - removal);
          if (now != old) {
            density[v] = now;
            local.include(i, j, k);
          }
        }
      }
#pragma omp critical(tsf_edit_changed_box)
    changed = changed.united(local);
  }
  volume.mark_modified(changed);
  return changed;
}

}  // namespace

VoxelBox voxels_near_box(const VolumeGeometry& g, const Vec3d& lo_mm, const Vec3d& hi_mm,
                         double margin_mm) {
  const Vec3d lo = g.tissue_to_index(lo_mm - Vec3d{margin_mm, margin_mm, margin_mm});
  const Vec3d hi = g.tissue_to_index(hi_mm + Vec3d{margin_mm, margin_mm, margin_mm});
  auto first = [](double x) {  // smallest integer >= x, guarded against huge values
    return static_cast<int>(std::max(-1.0, std::min(std::ceil(x), 2.0e9)));
  };
  auto past = [](double x) {  // one past the largest integer <= x
    return static_cast<int>(std::max(-1.0, std::min(std::floor(x) + 1.0, 2.0e9)));
  };
  const VoxelBox box{{first(lo.x), first(lo.y), first(lo.z)}, {past(hi.x), past(hi.y), past(hi.z)}};
  return box.intersected(VoxelBox::of_dims(g.dims));
}

VoxelBox ablate_sphere(VoxelVolume& volume, const SphereTool& sphere,
                       const RemovalOptions& options) {
  check_options(options, "ablate_sphere");
  require(std::isfinite(sphere.radius) && sphere.radius >= 0.0 && all_finite(sphere.centre),
          "ablate_sphere: sphere needs a finite centre and radius >= 0 (mm)");
  const VolumeGeometry& g = volume.geometry();
  const double h = falloff_half_width(g, options);
  const Vec3d r{sphere.radius, sphere.radius, sphere.radius};
  const VoxelBox box = voxels_near_box(g, sphere.centre - r, sphere.centre + r, h);
  // Row (j,k) meets the sphere grown by h where |x − cx| <= sqrt(R² − dy² − dz²).
  const double reach = sphere.radius + h;
  auto rows = [&](int j, int k, int& i0, int& i1) {
    const Vec3d p = g.index_to_tissue({0.0, double(j), double(k)});
    const double dy = p.y - sphere.centre.y, dz = p.z - sphere.centre.z;
    const double rest = reach * reach - dy * dy - dz * dz;
    if (rest < 0.0) {
      i1 = i0;
      return;
    }
    const double half = std::sqrt(rest) / g.spacing.x;
    const double cx = (sphere.centre.x - g.origin.x) / g.spacing.x;
    i0 = std::max(i0, static_cast<int>(std::ceil(cx - half)));
    i1 = std::min(i1, static_cast<int>(std::floor(cx + half)) + 1);
  };
  return apply_removal(
      volume, box, options,
      [&](int i, int j, int k) {
        const Vec3d p = g.index_to_tissue({double(i), double(j), double(k)});
        return falloff_weight(sphere_distance(sphere, p), h);
      },
      rows);
}

VoxelBox ablate_capsule(VoxelVolume& volume, const CapsuleTool& capsule,
                        const RemovalOptions& options) {
  check_options(options, "ablate_capsule");
  require(std::isfinite(capsule.radius) && capsule.radius >= 0.0 && all_finite(capsule.a) &&
              all_finite(capsule.b),
          "ablate_capsule: capsule needs finite ends and radius >= 0 (mm)");
  const VolumeGeometry& g = volume.geometry();
  const double h = falloff_half_width(g, options);
  const Vec3d lo{std::min(capsule.a.x, capsule.b.x), std::min(capsule.a.y, capsule.b.y),
                 std::min(capsule.a.z, capsule.b.z)};
  const Vec3d hi{std::max(capsule.a.x, capsule.b.x), std::max(capsule.a.y, capsule.b.y),
                 std::max(capsule.a.z, capsule.b.z)};
  const Vec3d r{capsule.radius, capsule.radius, capsule.radius};
  const VoxelBox box = voxels_near_box(g, lo - r, hi + r, h);
  return apply_removal(volume, box, options, [&](int i, int j, int k) {
    const Vec3d p = g.index_to_tissue({double(i), double(j), double(k)});
    return falloff_weight(capsule_distance(capsule, p), h);
  });
}

VoxelBox cut_swept_blade(VoxelVolume& volume, const BladeTool& blade, const ToolPose& from,
                         const ToolPose& to, const RemovalOptions& options) {
  check_options(options, "cut_swept_blade");
  const Vec3d& e = blade.half_extents;
  require(std::isfinite(e.x) && std::isfinite(e.y) && std::isfinite(e.z) && e.x >= 0 && e.y >= 0 &&
              e.z >= 0,
          "cut_swept_blade: blade half extents must be finite and >= 0 (mm)");
  require(all_finite(from.position) && all_finite(to.position),
          "cut_swept_blade: poses must have finite positions");
  const VolumeGeometry& g = volume.geometry();
  const double h = falloff_half_width(g, options);
  const ToolPose a{from.position, from.orientation.normalized()};
  const ToolPose b{to.position, to.orientation.normalized()};

  // Sub-steps: a blade point moves at most |Δp| + angle·|corner| between the two poses.
  const double corner = length(e);
  const double travel =
      length(b.position - a.position) + a.orientation.angle_to(b.orientation) * corner;
  const double step_mm = 0.5 * min_spacing(g);
  const int steps = std::max(1, static_cast<int>(std::ceil(travel / step_mm)));
  require(steps <= 100000, "cut_swept_blade: the sweep is " + std::to_string(travel) +
                               " mm long; split it into moves shorter than " +
                               std::to_string(100000 * step_mm) + " mm");
  std::vector<ToolPose> poses(static_cast<std::size_t>(steps) + 1);
  for (int s = 0; s <= steps; ++s) {
    const double t = static_cast<double>(s) / steps;
    poses[static_cast<std::size_t>(s)] = {a.position + (b.position - a.position) * t,
                                          Rotation::slerp(a.orientation, b.orientation, t)};
  }

  // Bounding box of every sub-step's box (each bounded by its corner sphere).
  Vec3d lo = poses[0].position, hi = poses[0].position;
  for (const ToolPose& p : poses) {
    lo = {std::min(lo.x, p.position.x), std::min(lo.y, p.position.y), std::min(lo.z, p.position.z)};
    hi = {std::max(hi.x, p.position.x), std::max(hi.y, p.position.y), std::max(hi.z, p.position.z)};
  }
  const Vec3d rc{corner, corner, corner};
  const VoxelBox box = voxels_near_box(g, lo - rc, hi + rc, h);
  if (box.empty()) return {};

  // Largest weight over the sub-steps, per voxel of `box`, so overlapping sub-steps remove once.
  const Int3 ext = box.extent();
  std::vector<float> weight(static_cast<std::size_t>(box.voxel_count()), 0.0f);
  auto at = [&](int i, int j, int k) -> float& {
    return weight[static_cast<std::size_t>(i - box.lo.x) +
                  static_cast<std::size_t>(ext.x) *
                      (static_cast<std::size_t>(j - box.lo.y) +
                       static_cast<std::size_t>(ext.y) * static_cast<std::size_t>(k - box.lo.z))];
  };
  for (const ToolPose& p : poses) {
    const VoxelBox sb = voxels_near_box(g, p.position - rc, p.position + rc, h).intersected(box);
    for (int k = sb.lo.z; k < sb.hi.z; ++k)
      for (int j = sb.lo.y; j < sb.hi.y; ++j)
        for (int i = sb.lo.x; i < sb.hi.x; ++i) {
          const Vec3d q = g.index_to_tissue({double(i), double(j), double(k)});
          const double d = blade_distance(blade, p, q);
          if (d >= h) continue;
          float& w = at(i, j, k);
          w = std::max(w, falloff_weight(d, h));
        }
  }
  return apply_removal(volume, box, options, [&](int i, int j, int k) { return at(i, j, k); });
}

namespace {

/// Calls write(i, j, k, voxel index) over `box`; it returns whether it changed the voxel. Marks
/// and returns the box of the changed voxels.
template <typename Write>
VoxelBox write_voxels(VoxelVolume& volume, const VoxelBox& box, const Write& write) {
  VoxelBox changed{};
  for (int k = box.lo.z; k < box.hi.z; ++k)
    for (int j = box.lo.y; j < box.hi.y; ++j)
      for (int i = box.lo.x; i < box.hi.x; ++i)
        if (write(i, j, k, volume.index(i, j, k))) changed.include(i, j, k);
  volume.mark_modified(changed);
  return changed;
}

/// Labels the voxels of `box` holding tissue for which `inside(position)` holds.
template <typename Inside>
VoxelBox label_where(VoxelVolume& volume, const VoxelBox& box, std::uint8_t label,
                     const Inside& inside) {
  if (box.empty()) return {};
  const VolumeGeometry& g = volume.geometry();
  const std::vector<float>& d = volume.density_data();
  std::uint8_t* l = volume.labels_for_tracked_write();
  return write_voxels(volume, box, [&](int i, int j, int k, std::size_t v) {
    if (d[v] <= 0.0f || l[v] == label) return false;
    if (!inside(g.index_to_tissue({double(i), double(j), double(k)}))) return false;
    l[v] = label;
    return true;
  });
}

}  // namespace

VoxelBox set_box(VoxelVolume& volume, const Vec3d& lo_mm, const Vec3d& hi_mm, float density,
                 std::optional<std::uint8_t> label) {
  require(std::isfinite(density) && density >= 0.0f && density <= 1.0f,
          "set_box: density must lie in [0,1], got " + std::to_string(density));
  require(all_finite(lo_mm) && all_finite(hi_mm), "set_box: box corners must be finite (mm)");
  const VoxelBox box = voxels_near_box(volume.geometry(), lo_mm, hi_mm, 0.0);
  if (box.empty()) return {};
  float* d = volume.density_for_tracked_write();
  std::uint8_t* l = volume.labels_for_tracked_write();
  return write_voxels(volume, box, [&](int, int, int, std::size_t v) {
    const bool relabel = label && l[v] != *label;
    if (d[v] == density && !relabel) return false;
    d[v] = density;
    if (label) l[v] = *label;
    return true;
  });
}

VoxelBox label_box(VoxelVolume& volume, const Vec3d& lo_mm, const Vec3d& hi_mm,
                   std::uint8_t label) {
  require(all_finite(lo_mm) && all_finite(hi_mm), "label_box: box corners must be finite (mm)");
  const VoxelBox box = voxels_near_box(volume.geometry(), lo_mm, hi_mm, 0.0);
  return label_where(volume, box, label, [](const Vec3d&) { return true; });
}

VoxelBox label_capsule(VoxelVolume& volume, const CapsuleTool& capsule, std::uint8_t label) {
  require(all_finite(capsule.a) && all_finite(capsule.b) && std::isfinite(capsule.radius) &&
              capsule.radius >= 0,
          "label_capsule: the capsule needs finite ends and a radius >= 0 (mm)");
  const Vec3d lo{std::min(capsule.a.x, capsule.b.x), std::min(capsule.a.y, capsule.b.y),
                 std::min(capsule.a.z, capsule.b.z)};
  const Vec3d hi{std::max(capsule.a.x, capsule.b.x), std::max(capsule.a.y, capsule.b.y),
                 std::max(capsule.a.z, capsule.b.z)};
  const VoxelBox box = voxels_near_box(volume.geometry(), lo, hi, capsule.radius);
  return label_where(volume, box, label,
                     [&](const Vec3d& p) { return capsule_distance(capsule, p) <= 0.0; });
}

VoxelBox clear_voxels(VoxelVolume& volume, const std::vector<VoxelBox>& boxes) {
  float* d = volume.density_for_tracked_write();
  const VoxelBox all = VoxelBox::of_dims(volume.dims());
  VoxelBox changed{};
  for (const VoxelBox& b : boxes)
    changed =
        changed.united(write_voxels(volume, b.intersected(all), [&](int, int, int, std::size_t v) {
          if (d[v] == 0.0f) return false;
          d[v] = 0.0f;
          return true;
        }));
  return changed;
}

}  // namespace tsf
