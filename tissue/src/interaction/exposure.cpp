#include "tsf/interaction/exposure.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

#include "tsf/volume/tissue_labels.h"

namespace tsf::interaction {

std::array<bool, 256> ExposureOptions::watched() const {
  std::array<bool, 256> w{};
  if (labels.empty()) {
    for (int l = kLabelFirstOverlay; l < kLabelFirstUser; ++l)
      w[static_cast<std::size_t>(l)] = true;
  } else {
    for (std::uint8_t l : labels) w[l] = true;
  }
  return w;
}

std::string exposure_event_name(std::uint8_t label) {
  return "exposure:" + std::to_string(static_cast<int>(label));
}

std::string describe_exposure(const ExposureHit& hit, const std::string& tool, double time_s) {
  const std::string label = tissue_label_key(hit.label);
  char buf[256];
  if (hit.distance_mm > 0)
    std::snprintf(buf, sizeof buf, "%s exposed: %s removed tissue %.2f mm from it at t = %.4g s",
                  label.c_str(), tool.c_str(), hit.distance_mm, time_s);
  else
    std::snprintf(buf, sizeof buf, "%s reached: %s removed %s tissue at t = %.4g s", label.c_str(),
                  tool.c_str(), label.c_str(), time_s);
  return buf;
}

std::vector<ExposureHit> find_exposures(const VoxelVolume& volume, const DensitySnapshot& before,
                                        const VoxelBox& changed, float iso,
                                        const ExposureOptions& options) {
  if (!options.enabled() || changed.empty()) return {};
  const std::array<bool, 256> watched = options.watched();
  const VoxelBox grid = VoxelBox::of_dims(volume.dims());
  const VoxelBox edit = changed.intersected(grid);

  // Removed voxels: solid before, below the iso-level now; or a watched voxel that lost density.
  struct Removed {
    Int3 at;
    std::uint8_t self_label;  // a watched label removed itself (distance 0), else 0
  };
  std::vector<Removed> removed;
  VoxelBox removed_box{};
  for (int k = edit.lo.z; k < edit.hi.z; ++k)
    for (int j = edit.lo.y; j < edit.hi.y; ++j)
      for (int i = edit.lo.x; i < edit.hi.x; ++i) {
        const float was = before.before(volume, i, j, k), now = volume.density(i, j, k);
        if (!(now < was)) continue;
        const std::uint8_t label = volume.label(i, j, k);
        const bool self = watched[label];
        if (!self && !(was >= iso && now < iso)) continue;
        removed.push_back({{i, j, k}, self ? label : std::uint8_t{0}});
        removed_box.include(i, j, k);
      }
  if (removed.empty()) return {};

  // Watched voxels holding tissue within reach of the removed ones.
  const Vec3d& s = volume.geometry().spacing;
  const double d = options.distance_mm;
  Int3 reach;
  for (int a = 0; a < 3; ++a) reach[a] = static_cast<int>(std::floor(d / s[a] + 1e-9));
  VoxelBox region = removed_box;
  for (int a = 0; a < 3; ++a) {
    region.lo[a] -= reach[a];
    region.hi[a] += reach[a];
  }
  region = region.intersected(grid);
  struct Watched {
    Int3 at;
    std::uint8_t label;
  };
  std::vector<Watched> near;
  for (int k = region.lo.z; k < region.hi.z; ++k)
    for (int j = region.lo.y; j < region.hi.y; ++j)
      for (int i = region.lo.x; i < region.hi.x; ++i) {
        const std::uint8_t label = volume.label(i, j, k);
        if (watched[label] && volume.density(i, j, k) > 0.0f) near.push_back({{i, j, k}, label});
      }

  std::array<double, 256> best;
  best.fill(std::numeric_limits<double>::infinity());
  std::array<Int3, 256> where{};
  auto consider = [&](std::uint8_t label, const Int3& label_at, double dist2) {
    if (dist2 < best[label]) {
      best[label] = dist2;
      where[label] = label_at;
    }
  };
  for (const Removed& r : removed)
    if (r.self_label != 0) consider(r.self_label, r.at, 0.0);

  // Nearest pairs: a mask of the removed voxels over `region`, searched around each watched voxel
  // within reach (the watched voxels near an edit are few; the reach is a few voxels).
  if (!near.empty()) {
    const Int3 ext = region.extent();
    std::vector<std::uint8_t> mask(static_cast<std::size_t>(region.voxel_count()), 0);
    auto at = [&](int i, int j, int k) {
      return static_cast<std::size_t>(i - region.lo.x) +
             static_cast<std::size_t>(ext.x) *
                 (static_cast<std::size_t>(j - region.lo.y) +
                  static_cast<std::size_t>(ext.y) * static_cast<std::size_t>(k - region.lo.z));
    };
    for (const Removed& r : removed) mask[at(r.at.x, r.at.y, r.at.z)] = 1;
    const double d2max = d * d + 1e-9;
    for (const Watched& w : near) {
      VoxelBox around{{w.at.x - reach.x, w.at.y - reach.y, w.at.z - reach.z},
                      {w.at.x + reach.x + 1, w.at.y + reach.y + 1, w.at.z + reach.z + 1}};
      around = around.intersected(removed_box);
      for (int k = around.lo.z; k < around.hi.z; ++k)
        for (int j = around.lo.y; j < around.hi.y; ++j)
          for (int i = around.lo.x; i < around.hi.x; ++i) {
            if (!mask[at(i, j, k)]) continue;
            const double dx = (i - w.at.x) * s.x, dy = (j - w.at.y) * s.y, dz = (k - w.at.z) * s.z;
            const double dist2 = dx * dx + dy * dy + dz * dz;
            if (dist2 <= d2max) consider(w.label, w.at, dist2);
          }
    }
  }

  std::vector<ExposureHit> hits;
  for (int l = 0; l < 256; ++l) {
    if (!std::isfinite(best[static_cast<std::size_t>(l)])) continue;
    ExposureHit h;
    h.label = static_cast<std::uint8_t>(l);
    h.distance_mm = std::sqrt(best[static_cast<std::size_t>(l)]);
    const Int3& p = where[static_cast<std::size_t>(l)];
    h.label_mm = volume.geometry().index_to_tissue({double(p.x), double(p.y), double(p.z)});
    hits.push_back(h);
  }
  return hits;
}

}  // namespace tsf::interaction
