#include "tsf/crms/effect_energy.h"

#include "tsf/crms/node_state_view.h"
#include "tsf/crms/stencil.h"

namespace tsf::crms {

double volume_energy_nj(const LatticeView& lat, const ConstStateView& st,
                        const VolumeParameters& p) {
  double energy = 0.0;
  for_each_volume_cube(lat, p, [&](std::int64_t c, int, int, int, float stiffness, float) {
    energy += intact_cube_volume_energy(lat, st, c, stiffness);
  });
  return energy;
}

double effects_elastic_energy_nj(const LatticeGeometry& g, const EffectEnergyInputs& in,
                                 const EffectParameters& p,
                                 const std::vector<RestOffsets>& rest_offsets,
                                 double bulk_modulus_pa) {
  if ((p.enabled &
       (effect_bits::kSpringEffects | effect_bits::kFluid | effect_bits::kVolumetric)) == 0)
    return 0.0;
  const auto count = static_cast<std::size_t>(g.node_count());
  std::vector<float> soa[3], zero(count, 0.0f);
  for (int a = 0; a < 3; ++a) {
    soa[a].resize(count);
    for (std::size_t n = 0; n < count; ++n) soa[a][n] = in.displacement_mm[n][a];
  }
  std::vector<std::uint32_t> material_index(count), material_weight(count);
  for (std::size_t n = 0; n < count; ++n) {
    material_index[n] = in.material[n].index;
    material_weight[n] = in.material[n].weight;
  }
  LatticeView lat;
  lat.dims = g.dims;
  lat.count = g.node_count();
  lat.stride_y = g.dims.x;
  lat.stride_z = static_cast<std::int64_t>(g.dims.x) * g.dims.y;
  for (int a = 0; a < 3; ++a) lat.rest_length[a] = static_cast<float>(g.spacing[a]);
  lat.flags = in.flags.data();
  lat.material_index = material_index.data();
  lat.material_weight = material_weight.data();
  ConstStateView st;
  for (int a = 0; a < 3; ++a) {
    st.u[a] = soa[a].data();
    st.v[a] = zero.data();
  }
  const EffectsState& effects = in.effects;
  double energy = 0.0;
  if (p.enabled & effect_bits::kVolumetric) energy += volume_energy_nj(lat, st, p.volume);
  for (std::int64_t n = 0; n < lat.count; ++n) {
    if ((in.flags[n] & kAliveBit) == 0) continue;
    const Int3 c = g.coordinates(n);
    const IndexedStencil s{lat, st, n, c.x, c.y, c.z};
    const unsigned links = in.flags[n] & kLinkBits;
    if (p.enabled & effect_bits::kSpringEffects)
      for (int ax = 0; ax < 3; ++ax) {
        const int d = make_direction(ax, 1);
        if (((links >> d) & 1u) == 0) continue;
        const Arm<float> arm = arm_of(s, links, s.u(0), s.v(0), lat.rest_length, d);
        float ks = 0, kd = 0;
        linear_constants(s, p, d, ks, kd);
        const double stretch = static_cast<double>(arm.stretch);
        double delta = effects.plastic_offset.empty()
                           ? 0.0
                           : static_cast<double>(effects.plastic_offset[n][ax]);
        if (!rest_offsets.empty()) {
          const double from = rest_offsets[static_cast<std::size_t>(p.rest_from_key)][ax][n];
          const double to = rest_offsets[static_cast<std::size_t>(p.rest_to_key)][ax][n];
          delta += from + static_cast<double>(p.rest_blend) * (to - from);
        }
        const double extra = (p.enabled & effect_bits::kAnisotropy)
                                 ? static_cast<double>(spring_aniso_extra(s, p, d))
                                 : 0.0;
        const double k_per_l = static_cast<double>(ks) / static_cast<double>(lat.rest_length[ax]);
        energy += 0.5 * k_per_l *
                  ((1.0 + extra) * (stretch - delta) * (stretch - delta) - stretch * stretch);
      }
    if ((p.enabled & effect_bits::kFluid) && cube_exists(lat, c.x, c.y, c.z)) {
      const double v0 = static_cast<double>(lat.rest_length[0]) *
                        static_cast<double>(lat.rest_length[1]) *
                        static_cast<double>(lat.rest_length[2]);
      const double strain =
          (static_cast<double>(cube_edges(lat, st, c.x, c.y, c.z).volume()) - v0) / v0;
      const double excess = strain - static_cast<double>(effects.fluid_content[n]);
      energy += 0.5 * bulk_modulus_pa * excess * excess * v0;
    }
  }
  return energy;
}

}  // namespace tsf::crms
