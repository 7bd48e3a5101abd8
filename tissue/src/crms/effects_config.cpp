#include "tsf/crms/effects_config.h"

#include <cmath>
#include <string>

#include "tsf/common/error.h"

namespace tsf::crms {

std::vector<std::string> EffectsConfig::active() const {
  std::vector<std::string> names;
  if (plasticity.enabled) names.emplace_back("plasticity");
  if (anisotropy.enabled) names.emplace_back("anisotropy");
  if (fluid.enabled) names.emplace_back("fluid");
  if (tearing.enabled) names.emplace_back("tearing");
  if (tearing.enabled && tearing.node_force_threshold_un > 0) names.emplace_back("node-masking");
  if (animation.enabled) names.emplace_back("animation");
  return names;
}

namespace {
void require_range(double value, double lo, double hi, bool lo_open, const char* field,
                   const char* unit) {
  const bool ok = std::isfinite(value) && (lo_open ? value > lo : value >= lo) && value <= hi;
  require(ok, std::string("effects.") + field + " = " + std::to_string(value) + unit +
                  " is out of range " + (lo_open ? "(" : "[") + std::to_string(lo) + ", " +
                  std::to_string(hi) + "]");
}
}  // namespace

void validate_effects_config(const EffectsConfig& e) {
  if (e.plasticity.enabled) {
    require_range(e.plasticity.yield_strain, 0, 10, true, "plasticity.yield_strain", "");
    require_range(e.plasticity.creep_rate, 0, 1e6, false, "plasticity.creep_rate", " 1/s");
    require_range(e.plasticity.recovery_rate, 0, 1e6, false, "plasticity.recovery_rate", " 1/s");
  }
  if (e.anisotropy.enabled) {
    const Vec3d a = e.anisotropy.axis;
    const double len = std::sqrt(a.x * a.x + a.y * a.y + a.z * a.z);
    require(std::isfinite(len) && len > 1e-12,
            "effects.anisotropy.axis must be a finite non-zero vector");
    require_range(e.anisotropy.stiffness_factor, 0.01, 100, false, "anisotropy.stiffness_factor",
                  "");
  }
  if (e.fluid.enabled) {
    require_range(e.fluid.bulk_modulus_pa, 1, 1e11, false, "fluid.bulk_modulus_pa", " Pa");
    require_range(e.fluid.diffusion_rate, 0, 1e6, false, "fluid.diffusion_rate", " 1/s");
  }
  if (e.tearing.enabled) {
    require_range(e.tearing.strain_threshold, 0, 100, true, "tearing.strain_threshold", "");
    if (e.tearing.node_force_threshold_un != 0)
      require_range(e.tearing.node_force_threshold_un, 0, 1e12, true,
                    "tearing.node_force_threshold", " µN");
  }
  if (e.animation.enabled) {
    const auto& keys = e.animation.rest_keyframes;
    for (std::size_t k = 0; k < keys.size(); ++k) {
      const std::string field = "animation.rest_keyframes[" + std::to_string(k) + "].time";
      require_range(keys[k].time_s, 0, 1e9, false, field.c_str(), " s");
      require(k == 0 || keys[k].time_s > keys[k - 1].time_s,
              "effects." + field + " = " + std::to_string(keys[k].time_s) +
                  " s: keyframe times must increase strictly");
      for (const Vec3f& r : keys[k].rest_displacement_mm)
        require(std::isfinite(r.x) && std::isfinite(r.y) && std::isfinite(r.z),
                "effects.animation.rest_keyframes[" + std::to_string(k) +
                    "] has a non-finite rest displacement");
    }
    for (std::size_t t = 0; t < e.animation.material_tracks.size(); ++t) {
      const MaterialTrack& track = e.animation.material_tracks[t];
      const std::string field = "animation.material_tracks[" + std::to_string(t) + "]";
      require_range(track.start_s, 0, 1e9, false, (field + ".start").c_str(), " s");
      require_range(track.end_s, track.start_s, 1e9, false, (field + ".end").c_str(), " s");
      require_range(track.entry, 0, 15, false, (field + ".entry").c_str(), "");
    }
    for (std::size_t t = 0; t < e.animation.cut_triggers.size(); ++t)
      require_range(e.animation.cut_triggers[t].entry, 0, 15, false,
                    ("animation.cut_triggers[" + std::to_string(t) + "].entry").c_str(), "");
  }
}

}  // namespace tsf::crms
