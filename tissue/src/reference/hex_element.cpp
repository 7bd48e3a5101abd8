// Element matrices of the trilinear hexahedron (hex_element.h).
#include "tsf/reference/hex_element.h"

#include <Eigen/Dense>
#include <cmath>
#include <sstream>

#include "tsf/common/error.h"

namespace tsf::reference {
namespace {

using Matrix6 = Eigen::Matrix<double, 6, 6>;
using Strain24 = Eigen::Matrix<double, 6, 24>;
using Strain9 = Eigen::Matrix<double, 6, 9>;

/// Voigt row of the strain that the gradient ∂u_component/∂x_axis contributes to.
int voigt_row(int component, int axis) {
  return component == axis ? axis : 3 + (3 - component - axis);
}

Matrix6 elasticity_matrix(const ElasticMaterial& m) {
  const double lambda = m.lame_lambda(), mu = m.shear_modulus();
  Matrix6 d = Matrix6::Zero();
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) d(i, j) = lambda;
    d(i, i) = lambda + 2.0 * mu;
    d(3 + i, 3 + i) = mu;
  }
  return d;
}

void fail_range(const std::string& field, double value, const char* range) {
  std::ostringstream s;
  s << field << " = " << value << " is out of range (expected " << range << ")";
  throw Error(s.str());
}

}  // namespace

void validate_elastic_material(const ElasticMaterial& m, const std::string& prefix) {
  if (!(m.youngs_modulus_pa >= 1.0 && m.youngs_modulus_pa <= 1e12))
    fail_range(prefix + ".youngs_modulus", m.youngs_modulus_pa, "[1, 1e12] Pa");
  if (!(m.poisson_ratio >= 0.0 && m.poisson_ratio <= 0.49))
    fail_range(prefix + ".poisson_ratio", m.poisson_ratio,
               "[0, 0.49]; the hexahedral reference avoids volumetric locking up to 0.49");
  if (!(m.density_g_per_mm3 >= 0.0 && m.density_g_per_mm3 <= 1.0))
    fail_range(prefix + ".density", m.density_g_per_mm3, "[0, 1] g/mm³");
}

const char* to_string(HexFormulation formulation) {
  switch (formulation) {
    case HexFormulation::kIncompatibleModes:
      return "incompatible-modes";
    case HexFormulation::kFullIntegration:
      return "full-integration";
    case HexFormulation::kMeanDilatation:
      return "mean-dilatation";
  }
  return "?";
}

HexElementMatrices hex_element_matrices(const Vec3d& size_mm, const ElasticMaterial& material,
                                        HexFormulation formulation) {
  validate_elastic_material(material);
  for (int a = 0; a < 3; ++a)
    if (!(size_mm[a] > 0.0 && std::isfinite(size_mm[a])))
      throw Error("hex element size must be finite and > 0 mm along every axis");
  const Matrix6 d = elasticity_matrix(material);
  const Vec3d half = size_mm * 0.5;
  const double det_j = half.x * half.y * half.z;
  const double g = 1.0 / std::sqrt(3.0);

  HexStiffness kuu = HexStiffness::Zero();
  Eigen::Matrix<double, 24, 9> kua = Eigen::Matrix<double, 24, 9>::Zero();
  Eigen::Matrix<double, 9, 9> kaa = Eigen::Matrix<double, 9, 9>::Zero();
  // Strain-displacement matrix at Gauss point gp (natural coordinates ±1/√3).
  auto strain_matrix = [&](int gp) {
    const double s[3] = {(gp & 1) ? g : -g, (gp & 2) ? g : -g, (gp & 4) ? g : -g};
    Strain24 b = Strain24::Zero();
    for (int c = 0; c < 8; ++c) {
      const double sc[3] = {(c & 1) ? 1.0 : -1.0, (c & 2) ? 1.0 : -1.0, (c & 4) ? 1.0 : -1.0};
      for (int axis = 0; axis < 3; ++axis) {
        // ∂N_c/∂x_axis = (1/half_axis)·(1/8)·sc_axis·Π_{other}(1 + sc·s)
        double dn = sc[axis] / (8.0 * half[axis]);
        for (int o = 0; o < 3; ++o)
          if (o != axis) dn *= 1.0 + sc[o] * s[o];
        // ∂u_component/∂x_axis enters ε_axis (component = axis) or one engineering shear
        for (int component = 0; component < 3; ++component)
          b(voigt_row(component, axis), 3 * c + component) += dn;
      }
    }
    return b;
  };
  // B-bar: the element mean of the volumetric row b_vol = Σ normal rows (equal Gauss weights).
  Eigen::Matrix<double, 1, 24> mean_volumetric = Eigen::Matrix<double, 1, 24>::Zero();
  if (formulation == HexFormulation::kMeanDilatation)
    for (int gp = 0; gp < 8; ++gp)
      mean_volumetric += strain_matrix(gp).topRows<3>().colwise().sum() / 8.0;
  for (int gp = 0; gp < 8; ++gp) {
    const double s[3] = {(gp & 1) ? g : -g, (gp & 2) ? g : -g, (gp & 4) ? g : -g};
    Strain24 b = strain_matrix(gp);
    if (formulation == HexFormulation::kMeanDilatation) {
      const Eigen::Matrix<double, 1, 24> shift =
          (mean_volumetric - b.topRows<3>().colwise().sum()) / 3.0;
      for (int r = 0; r < 3; ++r) b.row(r) += shift;
    }
    const double w = det_j;  // Gauss weights are 1
    kuu.noalias() += w * b.transpose() * d * b;
    if (formulation == HexFormulation::kIncompatibleModes) {
      Strain9 gm = Strain9::Zero();
      for (int k = 0; k < 3; ++k) {
        const double dp = -2.0 * s[k] / half[k];  // ∂(1 − s_k²)/∂x_k
        for (int component = 0; component < 3; ++component)
          gm(voigt_row(component, k), 3 * k + component) += dp;
      }
      kua.noalias() += w * b.transpose() * d * gm;
      kaa.noalias() += w * gm.transpose() * d * gm;
    }
  }

  HexElementMatrices out;
  if (formulation == HexFormulation::kIncompatibleModes) {
    const Eigen::LDLT<Eigen::Matrix<double, 9, 9>> kaa_ldlt(kaa);
    out.internal_modes = -kaa_ldlt.solve(kua.transpose());
    out.stiffness = kuu + kua * out.internal_modes;
    out.stiffness = 0.5 * (out.stiffness + out.stiffness.transpose()).eval();
  } else {
    out.stiffness = kuu;
    out.internal_modes.setZero();
  }
  return out;
}

}  // namespace tsf::reference
