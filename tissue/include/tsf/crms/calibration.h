// From material parameters (Young's modulus, shear modulus, viscosity, density) to CRMS spring
// constants, and what the lattice can and cannot express. Derivation and the test that checks it:
// docs/crms.md ("Calibration"), tests/tissue/crms/test_calibration.cpp.
//
// Small-strain elasticity of the lattice (cell hx×hy×hz, volume V, one node per cell):
//   * A linear spring along x carries the cell's cross-section hy·hz: under strain ε its force is
//     ks·ε, so the stress is ks/(hy·hz)·ε and    ks_x = E·hy·hz        (likewise y, z).
//   * Uniform strain along x changes no right angle, and no spring couples x to y:  C12 = 0.
//     The lattice's Poisson ratio is 0 along its axes, whatever the constants (a lattice with
//     central-force diagonal springs is the one locked near ν = 1/4 by the Cauchy relations;
//     CRMS has no diagonals). Lateral contraction (ν > 0) cannot be expressed; volume-preserving
//     behaviour needs the fluid-pressure effect (docs/effects.md, "The effects").
//   * Engineering shear γ in the xy plane changes the node's 4 xy angles by ±γ. With the
//     symmetric (potential) form the energy per cell is 4·½kθγ², so G = 4kθ/V. The gather form
//     keeps only the vertex terms of that potential's gradient; in the long-wave limit this is
//     exactly half the restoring force, G = 2kθ/V. Hence
//         kθ = G·V/4 (symmetric)   or   kθ = G·V/2 (gather, the thesis form).
//   * Isotropy of a cubic medium needs C44 = (C11 − C12)/2, i.e. G = E/2: the default. Other G
//     make the lattice cubic-anisotropic (stiffer or softer in shear than in tension), which the
//     thesis uses for "compressible but shear-resistant" or fabric-like tissue.
//   * Kelvin–Voigt viscosity η (σ = E·ε + η·ε̇) gives kd = η·A and cθ = kθ·η/E: every spring has
//     the same damping time τ = η/E (stiffness-proportional damping, damping ratio τ·ω/2 for a
//     mode of angular frequency ω).
//   * Mass: ρ·V per full cell (lattice_builders.h).
#pragma once

#include "tsf/common/vec3.h"
#include "tsf/crms/spring_constants.h"

namespace tsf::crms {

struct Material {
  double youngs_modulus_pa = 10e3;    ///< E, Pa (= g/(mm·s²)); documented range [1, 1e11]
  double shear_modulus_pa = 0.0;      ///< G, Pa; 0 = E/2 (isotropic); range (0, 10·E]
  double viscosity_pa_s = 0.0;        ///< Kelvin–Voigt η, Pa·s; range [0, 1e6]
  double density_g_per_mm3 = 1.0e-3;  ///< ρ, g/mm³; range [1e-6, 1e-1]
  // Per-material limits and axes of the optional effects (effects_config.h), used where the
  // lattice is heterogeneous (blended per node like the spring constants); 0 = the effect's own.
  double tear_strain = 0.0;        ///< tearing threshold of this material; 0 or (0, 100]
  double anisotropy_factor = 0.0;  ///< stiffness factor along anisotropy_axis; 0 or [0.01, 100]
  Vec3d anisotropy_axis{0.0, 0.0, 0.0};  ///< fibre direction (normalised); needed with a factor
  double effective_shear_modulus() const {
    return shear_modulus_pa > 0.0 ? shear_modulus_pa : 0.5 * youngs_modulus_pa;
  }
};

/// Throws tsf::Error naming the field, its value and the accepted range (prefix names the owner,
/// e.g. "material").
void validate_material(const Material& material, const char* prefix = "material");

/// Spring constants for a lattice of the given spacing (mm per axis); `symmetric_reactions`
/// selects the angular calibration of features::kSymmetricReactions (see header).
SpringConstants calibrate_springs(const Material& material, const Vec3d& spacing_mm,
                                  bool symmetric_reactions);

/// Small-strain moduli the lattice realises with the given constants (inverse of the above):
/// Young's moduli along x, y, z and shear moduli in the yz, zx, xy planes, Pa.
struct LatticeModuli {
  Vec3d youngs_pa;
  Vec3d shear_pa;
};
LatticeModuli lattice_moduli(const SpringConstants& springs, const Vec3d& spacing_mm,
                             bool symmetric_reactions);

}  // namespace tsf::crms
