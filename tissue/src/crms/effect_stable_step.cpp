#include "tsf/crms/effect_stable_step.h"

#include <algorithm>
#include <cmath>

#include "tsf/crms/animation_timeline.h"

namespace tsf::crms {

StableTimeStep stable_time_step_with_effects(const Lattice& lattice, const MaterialPalette& palette,
                                             const SolverConfig& config) {
  const bool symmetric = config.angular_reactions == AngularReactions::kSymmetric;
  const VolumeParameters volume = calibrate_volume(config.materials);
  StableTimeStep stable = estimate_stable_time_step(lattice, palette, symmetric, &volume);
  const AnimationConfig& animation = config.effects.animation;
  if (animation.enabled &&
      (!animation.material_tracks.empty() || !animation.cut_triggers.empty())) {
    const StableTimeStep at_targets = estimate_stable_time_step(
        AnimationTimeline::at_targets(animation, lattice), palette, symmetric, &volume);
    if (at_targets.symplectic_euler_s < stable.symplectic_euler_s) stable = at_targets;
  }
  double stiffening = 1.0;
  if (config.effects.anisotropy.enabled) {
    double factor = config.effects.anisotropy.stiffness_factor;
    if (palette.count > 1)
      for (const Material& m : config.materials) factor = std::max(factor, m.anisotropy_factor);
    stiffening *= std::max(1.0, factor);
  }
  if (config.effects.fluid.enabled) {
    double youngs_min = config.materials.front().youngs_modulus_pa;
    for (const Material& m : config.materials)
      youngs_min = std::min(youngs_min, m.youngs_modulus_pa);
    stiffening *= 1.0 + 3.0 * config.effects.fluid.bulk_modulus_pa / youngs_min;
  }
  if (stiffening > 1.0) {
    const double f = std::sqrt(stiffening);
    stable.symplectic_euler_s /= f;
    stable.explicit_euler_s /= f;
    stable.omega_max *= f;
  }
  return stable;
}

}  // namespace tsf::crms
