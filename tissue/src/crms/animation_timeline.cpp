#include "tsf/crms/animation_timeline.h"

#include <algorithm>
#include <cmath>
#include <string>

#include "tsf/common/error.h"
#include "tsf/crms/effect_physics.h"
#include "tsf/crms/lattice_builders.h"

namespace tsf::crms {

AnimationTimeline::AnimationTimeline(const AnimationConfig& a, const Lattice& lattice,
                                     int materials, int palette_count)
    : tracks_(a.material_tracks), triggers_(a.cut_triggers) {
  const std::int64_t count = lattice.node_count();
  require(
      (a.material_tracks.empty() && a.cut_triggers.empty()) || palette_count > 1,
      "effects.animation: material tracks and cut triggers need a heterogeneous palette (at least "
      "2 materials), the scene has 1");
  auto check_nodes = [&](const std::vector<std::int64_t>& nodes, const std::string& field) {
    for (std::int64_t n : nodes)
      require(n >= 0 && n < count, "effects.animation." + field + ": node " + std::to_string(n) +
                                       " is outside the lattice's " + std::to_string(count) +
                                       " nodes");
  };
  for (std::size_t t = 0; t < a.material_tracks.size(); ++t) {
    const std::string field = "material_tracks[" + std::to_string(t) + "]";
    check_nodes(a.material_tracks[t].nodes, field);
    require(a.material_tracks[t].entry < materials,
            "effects.animation." + field +
                ".entry = " + std::to_string(a.material_tracks[t].entry) + " but only " +
                std::to_string(materials) + " materials are configured");
  }
  for (std::size_t t = 0; t < a.cut_triggers.size(); ++t) {
    const std::string field = "cut_triggers[" + std::to_string(t) + "]";
    check_nodes(a.cut_triggers[t].nodes, field);
    require(a.cut_triggers[t].entry < materials,
            "effects.animation." + field + ".entry = " + std::to_string(a.cut_triggers[t].entry) +
                " but only " + std::to_string(materials) + " materials are configured");
    std::vector<std::int64_t> sorted = a.cut_triggers[t].nodes;
    std::sort(sorted.begin(), sorted.end());
    trigger_nodes_.push_back(std::move(sorted));
  }
  trigger_fired_.assign(a.cut_triggers.size(), false);
  track_origin_.resize(a.material_tracks.size());
  track_done_.assign(a.material_tracks.size(), false);

  // Rest keyframes → per-spring rest-length offsets |h·e + Δr| − h (the spring n → n+axis).
  if (a.rest_keyframes.empty()) return;
  const LatticeGeometry& g = lattice.geometry();
  auto offsets_of = [&](const std::vector<Vec3f>& r) {
    RestOffsets o;
    for (auto& c : o) c.assign(static_cast<std::size_t>(count), 0.0f);
    if (r.empty()) return o;
    for (std::int64_t n = 0; n < count; ++n)
      for (int ax = 0; ax < 3; ++ax) {
        const std::int64_t m = lattice.neighbour(n, make_direction(ax, 1));
        if (m < 0) continue;
        Vec3d edge = to_double(r[m]) - to_double(r[n]);
        edge[ax] += g.spacing[ax];
        o[ax][n] = static_cast<float>(std::sqrt(dot(edge, edge)) - g.spacing[ax]);
      }
    return o;
  };
  if (a.rest_keyframes.front().time_s > 0.0) {  // the grid's own rest shape until the first one
    rest_offsets_.push_back(offsets_of({}));
    rest_times_.push_back(0.0);
  }
  for (std::size_t k = 0; k < a.rest_keyframes.size(); ++k) {
    const std::vector<Vec3f>& r = a.rest_keyframes[k].rest_displacement_mm;
    require(r.empty() || static_cast<std::int64_t>(r.size()) == count,
            "effects.animation.rest_keyframes[" + std::to_string(k) + "] has " +
                std::to_string(r.size()) + " rest displacements, expected " +
                std::to_string(count) + " (one per lattice node)");
    rest_offsets_.push_back(offsets_of(r));
    rest_times_.push_back(a.rest_keyframes[k].time_s);
  }
}

void AnimationTimeline::set_time(EffectParameters& p, double time_s) const {
  if (rest_times_.empty()) return;
  std::size_t to = 0;
  while (to < rest_times_.size() && rest_times_[to] <= time_s) ++to;
  if (to == 0 || to == rest_times_.size()) {  // before the first / after the last: hold it
    const int k = to == 0 ? 0 : static_cast<int>(rest_times_.size()) - 1;
    p.rest_from_key = p.rest_to_key = k;
    p.rest_blend = 0.0f;
    return;
  }
  p.rest_from_key = static_cast<int>(to) - 1;
  p.rest_to_key = static_cast<int>(to);
  p.rest_blend =
      static_cast<float>((time_s - rest_times_[to - 1]) / (rest_times_[to] - rest_times_[to - 1]));
}

void AnimationTimeline::apply_material_tracks(double time_s, Lattice& lattice,
                                              const MaterialUpdate& update) {
  for (std::size_t t = 0; t < tracks_.size(); ++t) {
    const MaterialTrack& track = tracks_[t];
    if (track_done_[t] || time_s < track.start_s) continue;
    if (track_origin_[t].empty())
      for (std::int64_t n : track.nodes) track_origin_[t].push_back(lattice.material(n));
    const double s = track.end_s > track.start_s
                         ? std::min(1.0, (time_s - track.start_s) / (track.end_s - track.start_s))
                         : 1.0;
    std::vector<MaterialBlend> blends(track.nodes.size());
    for (std::size_t i = 0; i < track.nodes.size(); ++i) {
      // The target entry plus the origin's 3 heaviest components (make_material_blend sorts).
      const MaterialBlend o = track_origin_[t][i];
      const std::array<int, 4> entries{track.entry, o.entry(0), o.entry(1), o.entry(2)};
      const std::array<double, 4> shares{255.0 * s, (1.0 - s) * o.weight_of(0),
                                         (1.0 - s) * o.weight_of(1), (1.0 - s) * o.weight_of(2)};
      blends[i] = make_material_blend(entries, shares);
      lattice.set_material(track.nodes[i], blends[i]);
    }
    update(track.nodes, blends);
    track_done_[t] = s >= 1.0;
  }
}

void AnimationTimeline::fire(std::size_t t, Lattice& lattice, const MaterialUpdate& update) {
  std::vector<MaterialBlend> blends(triggers_[t].nodes.size(),
                                    MaterialBlend::single(triggers_[t].entry));
  for (std::int64_t n : triggers_[t].nodes) lattice.set_material(n, blends.front());
  update(triggers_[t].nodes, blends);
  trigger_fired_[t] = true;
  fired_triggers_.push_back(triggers_[t].name.empty() ? "cut trigger " + std::to_string(t)
                                                      : triggers_[t].name);
}

void AnimationTimeline::fire_cut_triggers(const std::vector<std::int64_t>& edited, Lattice& lattice,
                                          const MaterialUpdate& update) {
  for (std::size_t t = 0; t < triggers_.size(); ++t) {
    if (trigger_fired_[t] || !triggers_[t].event.empty()) continue;
    bool hit = false;
    for (std::int64_t n : edited)
      hit = hit || std::binary_search(trigger_nodes_[t].begin(), trigger_nodes_[t].end(), n);
    if (hit) fire(t, lattice, update);
  }
}

std::size_t AnimationTimeline::fire_event_triggers(const std::string& event, Lattice& lattice,
                                                   const MaterialUpdate& update) {
  std::size_t fired = 0;
  for (std::size_t t = 0; t < triggers_.size(); ++t)
    if (!trigger_fired_[t] && !event.empty() && triggers_[t].event == event) {
      fire(t, lattice, update);
      ++fired;
    }
  return fired;
}

Lattice AnimationTimeline::at_targets(const AnimationConfig& config, const Lattice& lattice) {
  Lattice target = lattice;
  for (const MaterialTrack& t : config.material_tracks)
    for (std::int64_t n : t.nodes) target.set_material(n, t.entry);
  for (const CutTrigger& t : config.cut_triggers)
    for (std::int64_t n : t.nodes) target.set_material(n, t.entry);
  return target;
}

}  // namespace tsf::crms
