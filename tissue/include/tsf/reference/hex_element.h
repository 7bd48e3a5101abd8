// The 8-node trilinear hexahedron of the linear-elastic FEM reference (fem_hex.h): isotropic
// material, element matrices of an axis-aligned box element (one lattice or voxel cell).
//
// Corners c = 0..7 sit at (cx, cy, cz) = (c & 1, (c >> 1) & 1, (c >> 2) & 1) in cell units; the
// element's 24 displacement unknowns are ordered u[3c + axis] (mm). Strains in Voigt order
// ε = [εxx, εyy, εzz, γyz, γzx, γxy]; stress σ = D·ε with the isotropic
//   D = λ·(1 1ᵀ on the normal block) + μ·diag(2, 2, 2, 1, 1, 1),
//   λ = Eν / ((1 + ν)(1 − 2ν)),  μ = E / (2(1 + ν))      (Pa).
// Stiffness K = ∫ Bᵀ D B dV, 2×2×2 Gauss points (exact for a box: the integrand is at most
// quadratic per axis). Units: K in µN/mm, so K·u is a force in µN.
//
// Formulations:
//  * kFullIntegration: the plain trilinear element (ABAQUS C3D8). It is too stiff in bending
//    (parasitic shear: a linear displacement field cannot bend an element without shearing it)
//    and locks volumetrically as ν → ½. Kept as the textbook baseline the tests compare against.
//  * kIncompatibleModes (the default): Wilson's incompatible modes in Taylor's form (R. L. Taylor,
//    P. J. Beresford, E. L. Wilson, "A non-conforming element for stress analysis", Int. J. Numer.
//    Meth. Eng. 10:1211–1219, 1976; ABAQUS C3D8I). Nine internal displacement modes
//    u_a += (1 − s_k²)·α_{k,a} (k = axis of the bubble, a = displacement component, s the natural
//    coordinate in [−1, 1]) are condensed out per element: K = Kuu − Kuα Kαα⁻¹ Kαu. The element
//    represents pure bending of a box exactly (no parasitic shear) and its bubbles relax the
//    volumetric constraint, so it neither shear-locks nor (for ν ≤ 0.49) volume-locks in bending
//    (test: FemHex.NearIncompressibleBendingIsNotLocked). For a box the Jacobian is constant, so
//    ∫ ∂(1 − s²)/∂x dV = 0 and the element passes the patch test (FemHex.PatchTest*). Loads are
//    not applied to the internal modes (Taylor's rule). After the solve α = R·u_e
//    (internal_modes below) restores the full displacement field inside the element.
//  * kMeanDilatation: the B-bar element of Hughes (T. J. R. Hughes, "Generalization of selective
//    integration procedures to anisotropic and nonlinear media", Int. J. Numer. Meth. Eng.
//    15:1413–1418, 1980; ABAQUS C3D8 with its "hybrid-free" selective form): the volumetric part
//    of B at every Gauss point is replaced by its element mean, B̄ = B + ⅓·m·(b̄_vol − b_vol),
//    m = [1 1 1 0 0 0]ᵀ, so the volume change is one constraint per element and cannot lock as
//    ν → ½ (it still shear-locks in bending like full integration). The independent check of the
//    incompatible-mode element near incompressibility (the accuracy report's Poisson study).
#pragma once

#include <Eigen/Core>
#include <string>

#include "tsf/common/vec3.h"

namespace tsf::reference {

/// Isotropic linear elasticity and mass density of one material.
struct ElasticMaterial {
  double youngs_modulus_pa = 10e3;    ///< E, Pa (= g/(mm·s²)); range [1, 1e12]
  double poisson_ratio = 0.0;         ///< ν, range [0, 0.49] (no volumetric locking up to 0.49)
  double density_g_per_mm3 = 1.0e-3;  ///< ρ, g/mm³ (gravity loads); range [0, 1]
  double lame_lambda() const {
    const double nu = poisson_ratio;
    return youngs_modulus_pa * nu / ((1.0 + nu) * (1.0 - 2.0 * nu));
  }
  double shear_modulus() const { return youngs_modulus_pa / (2.0 * (1.0 + poisson_ratio)); }
};

/// Throws tsf::Error naming `prefix`.field, its value and the accepted range.
void validate_elastic_material(const ElasticMaterial& material,
                               const std::string& prefix = "material");

enum class HexFormulation {
  kIncompatibleModes,  ///< Taylor–Wilson incompatible modes (C3D8I), the default
  kFullIntegration,    ///< plain trilinear, 2×2×2 Gauss (C3D8)
  kMeanDilatation,     ///< B-bar: volumetric strain at its element mean (no volumetric locking)
};
const char* to_string(HexFormulation formulation);

using HexStiffness = Eigen::Matrix<double, 24, 24>;
using HexInternalModes = Eigen::Matrix<double, 9, 24>;

struct HexElementMatrices {
  HexStiffness stiffness;  ///< condensed 24×24, µN/mm, symmetric positive semi-definite
  /// α = internal_modes · u_e: the 9 bubble amplitudes (mm), row 3k + a for bubble axis k and
  /// displacement component a. Zero for kFullIntegration and kMeanDilatation.
  HexInternalModes internal_modes;
};

/// Element matrices of a box element of `size_mm` (hx, hy, hz).
HexElementMatrices hex_element_matrices(const Vec3d& size_mm, const ElasticMaterial& material,
                                        HexFormulation formulation);

/// Trilinear shape function of corner c at local coordinates w ∈ [0,1]³ of the cell.
inline double hex_shape(int corner, const Vec3d& w) {
  const double sx = (corner & 1) ? w.x : 1.0 - w.x;
  const double sy = (corner & 2) ? w.y : 1.0 - w.y;
  const double sz = (corner & 4) ? w.z : 1.0 - w.z;
  return sx * sy * sz;
}

/// Bubble k of the incompatible modes at local coordinates w: 1 − s², s = 2·w[k] − 1.
inline double hex_bubble(int axis, const Vec3d& w) {
  const double s = 2.0 * w[axis] - 1.0;
  return 1.0 - s * s;
}

}  // namespace tsf::reference
