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
  if (e.tearing.enabled)
    require_range(e.tearing.strain_threshold, 0, 100, true, "tearing.strain_threshold", "");
}

}  // namespace tsf::crms
