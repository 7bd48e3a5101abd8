// The stable time step of the explicit CRMS integrators for one scene (lattice + materials).
//
// Derivation (docs/crms.md, "Stable time step"). Linearised at rest, a node's highest-frequency
// motion along axis a is the checkerboard mode (neighbours move opposite). Its stiffness is
//   λ_a = Σ_{links along a} 2·ks/L_a  +  r·Σ_{angles in planes (a,b)} 2·kθ/h_b²
// (each linear spring stretches by 2u; each right angle turns by 2u/h_b; r = 1 for the gather
// form, 2 with symmetric reactions), its damping c_a is the same sum with kd and cθ, and with the
// node's mass m:  ω = √(λ_a/m),  ζ = c_a/(2√(λ_a·m)). For an infinite uniform lattice this is the
// exact top of the spectrum (plane-wave analysis); at surfaces and material interfaces the local
// value is an estimate, checked against the power-iteration spectral radius in
// test_stable_time_step.cpp. Per scheme, for a damped oscillator (ω, ζ):
//   symplectic Euler:  dt < (2/ω)·(√(1+ζ²) − ζ)          (2/ω undamped: "2·√(m/k_max)")
//   explicit Euler:    dt < 2ζ/ω = c/λ when ζ < 1, else 2/(ω·(ζ + √(ζ²−1)));
//                      every lower mode also needs dt < c/k, the spring damping time τ = η/E
//                      (stiffness-proportional damping): explicit Euler without damping is
//                      unconditionally unstable (dt = 0).
// The minimum over nodes and axes is reported, with the node that sets it.
//
// Volumetric term (materials with ν > 0, volume_term.h): its stiffness at rest, Σ_c k_c/V0·g_c
// g_cᵀ, couples the three components (a lone cube's top mode is its breathing mode), so the
// checkerboard alone underestimates it on thin parts. Its M⁻¹K has the eigenvalues of the cubes'
// Gram matrix S_cd = √(k_c·k_d)/V0·Σ_{n ∈ c∩d} g_cn·g_dn/m_n, and Gershgorin's row of S bounds the
// term's top mode: each node takes the largest row among its cubes (6·λ·h/m inside a uniform
// lattice, where the exact top is the checkerboard's 4·λ·h/m; 1.5·k·h/m for a lone cube) and adds
// it to λ_a of every axis, with the rows of η to c_a.
#pragma once

#include <cstdint>

#include "tsf/crms/lattice.h"
#include "tsf/crms/spring_constants.h"
#include "tsf/crms/volume_term.h"

namespace tsf::crms {

struct StableTimeStep {
  double symplectic_euler_s = 0;    ///< largest stable dt of symplectic Euler, s
  double explicit_euler_s = 0;      ///< largest stable dt of explicit Euler, s (0: unstable)
  double omega_max = 0;             ///< highest angular frequency estimate, rad/s
  double zeta_at_omega_max = 0;     ///< damping ratio of that mode
  double damping_time_s = 0;        ///< min over springs of kd/ks and cθ/kθ, s
  std::int64_t critical_node = -1;  ///< node whose mode sets the symplectic bound
};

/// `volume`: the volumetric term's moduli (calibrate_volume), nullptr or all zero: none.
StableTimeStep estimate_stable_time_step(const Lattice& lattice, const MaterialPalette& palette,
                                         bool symmetric_reactions,
                                         const VolumeParameters* volume = nullptr);

}  // namespace tsf::crms
