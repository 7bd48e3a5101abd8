#include "tsf/viewer/surface_exchange.h"

#include <algorithm>
#include <cstring>

namespace tsf::viewer {

void merge_ranges(std::vector<std::pair<std::uint32_t, std::uint32_t>>& into,
                  const std::vector<std::pair<std::uint32_t, std::uint32_t>>& add) {
  if (add.empty()) return;
  std::vector<std::pair<std::uint32_t, std::uint32_t>> all;
  all.reserve(into.size() + add.size());
  std::merge(into.begin(), into.end(), add.begin(), add.end(), std::back_inserter(all));
  into.clear();
  for (const auto& r : all) {
    if (r.first >= r.second) continue;
    if (!into.empty() && r.first <= into.back().second)
      into.back().second = std::max(into.back().second, r.second);
    else
      into.push_back(r);
  }
}

void SurfaceExchange::publish(const interaction::TissueModel& model, bool topology_changed,
                              const SimulationStats& stats) {
  const coupler::Coupler& c = model.coupler();
  const imt::ImtSurface& s = model.surface();
  const std::uint32_t slots = std::min<std::uint32_t>(c.slot_count(), s.vertex_slot_count());
  std::lock_guard<std::mutex> lock(mutex_);
  stats_ = stats;
  if (first_ || topology_changed || shared_.positions.size() != slots ||
      shared_.triangles.size() != s.triangle_slot_count()) {
    first_ = false;
    shared_.positions.assign(c.positions().begin(), c.positions().begin() + slots);
    shared_.normals.assign(c.normals().begin(), c.normals().begin() + slots);
    shared_.labels.assign(s.labels().begin(), s.labels().begin() + slots);
    shared_.triangles.assign(s.triangles().begin(),
                             s.triangles().begin() + s.triangle_slot_count());
    shared_.live_triangles = s.live_triangle_count();
    pending_.topology = true;
    pending_.ranges.clear();
  } else {
    scratch_ = c.changed_ranges(coupler_version_);
    for (auto& r : scratch_) {
      r.second = std::min(r.second, slots);
      if (r.first >= r.second) continue;
      const std::size_t n = r.second - r.first;
      std::memcpy(shared_.positions.data() + r.first, c.positions().data() + r.first,
                  n * sizeof(Vec3f));
      std::memcpy(shared_.normals.data() + r.first, c.normals().data() + r.first,
                  n * sizeof(Vec3f));
    }
    if (!pending_.topology) merge_ranges(pending_.ranges, scratch_);
  }
  coupler_version_ = c.version();
}

void SurfaceExchange::publish_stats(const SimulationStats& stats) {
  std::lock_guard<std::mutex> lock(mutex_);
  stats_ = stats;
}

SimulationStats SurfaceExchange::consume(
    const std::function<void(const SurfaceBuffers&, const SurfaceDelta&)>& apply) {
  std::lock_guard<std::mutex> lock(mutex_);
  apply(shared_, pending_);
  pending_.topology = false;
  pending_.ranges.clear();
  return stats_;
}

std::uint64_t SurfaceExchange::published_version() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return coupler_version_;
}

}  // namespace tsf::viewer
