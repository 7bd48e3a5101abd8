#include "tsf/crms/calibration.h"

#include <cmath>
#include <cstdio>
#include <string>

#include "tsf/common/error.h"

namespace tsf::crms {
namespace {

void check_range(double value, double lo, double hi, bool lo_open, const std::string& field,
                 const char* unit) {
  const bool ok = std::isfinite(value) && (lo_open ? value > lo : value >= lo) && value <= hi;
  if (!ok) {
    char range[96];
    std::snprintf(range, sizeof range, "%c%g, %g]", lo_open ? '(' : '[', lo, hi);
    throw Error(field + " = " + std::to_string(value) + " " + unit + " is out of range " + range);
  }
}

}  // namespace

void validate_material(const Material& m, const char* prefix) {
  const std::string p = prefix;
  check_range(m.youngs_modulus_pa, 1.0, 1e11, false, p + ".youngs_modulus", "Pa");
  if (m.shear_modulus_pa != 0.0)
    check_range(m.shear_modulus_pa, 0.0, 10.0 * m.youngs_modulus_pa, true, p + ".shear_modulus",
                "Pa");
  check_range(m.viscosity_pa_s, 0.0, 1e6, false, p + ".viscosity", "Pa·s");
  check_range(m.poisson_ratio, 0.0, kMaxPoissonRatio, false, p + ".poisson_ratio", "");
  check_range(m.volume_damping_time_s, 0.0, 1.0, false, p + ".volume_damping_time", "s");
  check_range(m.density_g_per_mm3, 1e-6, 1e-1, false, p + ".density", "g/mm³");
  if (m.tear_strain != 0.0) check_range(m.tear_strain, 0.0, 100.0, true, p + ".tear_strain", "");
  if (m.anisotropy_factor != 0.0) {
    check_range(m.anisotropy_factor, 0.01, 100.0, false, p + ".anisotropy_factor", "");
    const Vec3d a = m.anisotropy_axis;
    const double len = std::sqrt(a.x * a.x + a.y * a.y + a.z * a.z);
    require(std::isfinite(len) && len > 1e-12,
            p + ".anisotropy_axis must be a finite non-zero vector with anisotropy_factor");
  }
}

SpringConstants calibrate_springs(const Material& m, const Vec3d& h, bool symmetric_reactions) {
  validate_material(m);
  const double volume = h.x * h.y * h.z;
  const double g = m.effective_shear_modulus();
  const double e_springs = m.spring_youngs_modulus();  // E/(1 + ν), see header
  const double tau = m.damping_time_s();
  const double angular_factor = symmetric_reactions ? 0.25 : 0.5;
  SpringConstants s;
  for (int a = 0; a < 3; ++a) {
    const double area = volume / h[a];
    s.ks_linear[a] = static_cast<float>(e_springs * area);
    s.kd_linear[a] = static_cast<float>(m.viscosity_pa_s / (1.0 + m.poisson_ratio) * area);
    const double k_theta = g * volume * angular_factor;
    s.k_angular[a] = static_cast<float>(k_theta);
    s.c_angular[a] = static_cast<float>(k_theta * tau);
  }
  return s;
}

VolumeParameters calibrate_volume(const std::vector<Material>& materials) {
  VolumeParameters v;
  v.heterogeneous = materials.size() > 1;
  for (std::size_t m = 0; m < materials.size() && m < static_cast<std::size_t>(kMaxMaterials);
       ++m) {
    const double lambda = materials[m].lame_lambda_pa();
    v.lambda[m] = static_cast<float>(lambda);
    v.damping[m] = static_cast<float>(lambda * materials[m].volume_damping_time_s);
  }
  return v;
}

LatticeModuli lattice_moduli(const SpringConstants& s, const Vec3d& h, bool symmetric_reactions) {
  const double volume = h.x * h.y * h.z;
  const double angular_factor = symmetric_reactions ? 4.0 : 2.0;
  LatticeModuli m;
  for (int a = 0; a < 3; ++a) {
    m.youngs_pa[a] = static_cast<double>(s.ks_linear[a]) / (volume / h[a]);
    m.shear_pa[a] = angular_factor * static_cast<double>(s.k_angular[a]) / volume;
  }
  return m;
}

}  // namespace tsf::crms
