// From material parameters (Young's modulus, shear modulus, viscosity, density) to CRMS spring
// constants, and what the lattice can and cannot express. Derivation and the test that checks it:
// docs/crms.md ("Calibration"), tests/tissue/crms/test_calibration.cpp.
//
// Small-strain elasticity of the lattice (cell hx×hy×hz, volume V, one node per cell):
//   * A linear spring along x carries the cell's cross-section hy·hz: under strain ε its force is
//     ks·ε, so the stress is ks/(hy·hz)·ε and    ks_x = E·hy·hz        (likewise y, z).
//   * Uniform strain along x changes no right angle, and no spring couples x to y:  C12 = 0.
//     The springs alone have Poisson ratio 0 along the axes, whatever the constants (a lattice
//     with central-force diagonal springs is the one locked near ν = 1/4 by the Cauchy
//     relations; CRMS has no diagonals).
//   * Poisson ratio ν > 0: the volumetric term (volume_term.h) adds the energy ½λ(tr ε)² per unit
//     volume, i.e. λ to C11 and to C12. Springs of modulus E_s with it give C11 = E_s + λ,
//     C12 = λ, C44 = G; an isotropic material has C11 = λ + 2μ, C12 = λ, C44 = μ. Hence
//         E_s = 2μ = E/(1 + ν),   λ = Eν/((1 + ν)(1 − 2ν)),   G = μ = E_s/2 (default)
//     reproduce the material's Lamé response exactly; along an axis the lattice then has Young's
//     modulus E_s(E_s + 3λ)/(E_s + 2λ) = E and Poisson ratio λ/(E_s + 2λ) = ν whatever G is
//     (docs/crms.md, "Calibration"). ν = 0 is the springs alone, unchanged.
//   * Engineering shear γ in the xy plane changes the node's 4 xy angles by ±γ. With the
//     symmetric (potential) form the energy per cell is 4·½kθγ², so G = 4kθ/V. The gather form
//     keeps only the vertex terms of that potential's gradient; in the long-wave limit this is
//     exactly half the restoring force, G = 2kθ/V. Hence
//         kθ = G·V/4 (symmetric)   or   kθ = G·V/2 (gather, the thesis form).
//   * Isotropy of a cubic medium needs C44 = (C11 − C12)/2, i.e. G = E/2: the default. Other G
//     make the lattice cubic-anisotropic (stiffer or softer in shear than in tension), which the
//     thesis uses for "compressible but shear-resistant" or fabric-like tissue.
//   * Kelvin–Voigt viscosity η (σ = E·ε + η·ε̇) gives kd = η·A·E_s/E and cθ = kθ·η/E: every
//     spring has the same damping time τ = η/E (stiffness-proportional damping, damping ratio
//     τ·ω/2 for a mode of angular frequency ω). With ν > 0 the viscous stress is the springs',
//     2μτ·ε̇ (Lamé viscosities μτ and 0): the volumetric term is elastic unless the material
//     gives it a damping time of its own (volume_damping_time_s, viscosity λ·τ_v). Damping λ
//     with τ would make the top mode's damping grow with λ and the explicit step shrink as 1/λ
//     once overdamped (docs/effects.md, "Volumetric term").
//   * Mass: ρ·V per full cell (lattice_builders.h).
#pragma once

#include <vector>

#include "tsf/common/vec3.h"
#include "tsf/crms/spring_constants.h"
#include "tsf/crms/volume_term.h"

namespace tsf::crms {

/// The largest Poisson ratio a material may have: λ = Eν/((1 + ν)(1 − 2ν)) is 166·E there (and
/// infinite at ½); the explicit step shrinks with √λ (docs/crms.md, "Stable time step").
constexpr double kMaxPoissonRatio = 0.499;

struct Material {
  double youngs_modulus_pa = 10e3;  ///< E, Pa (= g/(mm·s²)); documented range [1, 1e11]
  double shear_modulus_pa = 0.0;    ///< G, Pa; 0 = E/(2(1 + ν)) (isotropic); range (0, 10·E]
  /// ν, range [0, 0.499]; > 0 switches the volumetric term on for this material (an effect:
  /// ν = 0 costs nothing) and softens the springs to E/(1 + ν) (see header).
  double poisson_ratio = 0.0;
  /// τ_v, s, range [0, 1]: Kelvin–Voigt damping of the volumetric term (viscosity λ·τ_v). 0 (the
  /// default): the term is elastic and the material's viscosity acts through the springs alone
  /// (see header).
  double volume_damping_time_s = 0.0;
  double viscosity_pa_s = 0.0;        ///< Kelvin–Voigt η, Pa·s; range [0, 1e6]
  double density_g_per_mm3 = 1.0e-3;  ///< ρ, g/mm³; range [1e-6, 1e-1]
  // Per-material limits and axes of the optional effects (effects_config.h), used where the
  // lattice is heterogeneous (blended per node like the spring constants); 0 = the effect's own.
  double tear_strain = 0.0;        ///< tearing threshold of this material; 0 or (0, 100]
  double anisotropy_factor = 0.0;  ///< stiffness factor along anisotropy_axis; 0 or [0.01, 100]
  Vec3d anisotropy_axis{0.0, 0.0, 0.0};  ///< fibre direction (normalised); needed with a factor
  /// E_s = 2μ = E/(1 + ν): the modulus the linear springs carry.
  double spring_youngs_modulus() const { return youngs_modulus_pa / (1.0 + poisson_ratio); }
  /// λ = Eν/((1 + ν)(1 − 2ν)), Pa: the volumetric term's modulus (0 when ν = 0).
  double lame_lambda_pa() const {
    const double nu = poisson_ratio;
    return youngs_modulus_pa * nu / ((1.0 + nu) * (1.0 - 2.0 * nu));
  }
  /// τ = η/E, s: the damping time of every spring and of the volumetric term.
  double damping_time_s() const { return viscosity_pa_s / youngs_modulus_pa; }
  double effective_shear_modulus() const {
    return shear_modulus_pa > 0.0 ? shear_modulus_pa : 0.5 * spring_youngs_modulus();
  }
};

/// Throws tsf::Error naming the field, its value and the accepted range (prefix names the owner,
/// e.g. "material").
void validate_material(const Material& material, const char* prefix = "material");

/// Spring constants for a lattice of the given spacing (mm per axis); `symmetric_reactions`
/// selects the angular calibration of features::kSymmetricReactions (see header).
SpringConstants calibrate_springs(const Material& material, const Vec3d& spacing_mm,
                                  bool symmetric_reactions);

/// The volumetric term's moduli per palette entry: λ = Eν/((1 + ν)(1 − 2ν)) and its viscosity
/// λ·τ_v (zeros for ν = 0); heterogeneous when there is more than one material.
VolumeParameters calibrate_volume(const std::vector<Material>& materials);

/// Small-strain moduli the springs realise with the given constants (inverse of the above):
/// Young's moduli along x, y, z and shear moduli in the yz, zx, xy planes, Pa (the springs'
/// E_s, without the volumetric term of a material with ν > 0).
struct LatticeModuli {
  Vec3d youngs_pa;
  Vec3d shear_pa;
};
LatticeModuli lattice_moduli(const SpringConstants& springs, const Vec3d& spacing_mm,
                             bool symmetric_reactions);

}  // namespace tsf::crms
