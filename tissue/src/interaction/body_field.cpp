#include "tsf/interaction/body_field.h"

#include <algorithm>
#include <cmath>

#include "tsf/common/error.h"
#include "tsf/interaction/tissue_model.h"

namespace tsf::interaction {

BodyField::BodyField(const TissueModel& body, double spacing_mm) : spacing_mm_(spacing_mm) {
  require(std::isfinite(spacing_mm) && spacing_mm > 0,
          "body contact: the grid spacing must be > 0 mm, got " + std::to_string(spacing_mm));
  build_grid(body);
  follow(body);
}

void BodyField::build_grid(const TissueModel& body) {
  const imt::SurfaceMesh rest = body.surface().compact();
  try {
    grid_ = std::make_shared<collision::SignedDistanceGrid>(
        collision::SignedDistanceGrid::from_closed_mesh(rest.positions, rest.triangles, spacing_mm_,
                                                        2.0 * spacing_mm_));
  } catch (const Error& e) {
    throw Error(std::string("body contact: the pushing tissue's surface: ") + e.what());
  }
  edits_seen_ = body.totals().edits;
}

void BodyField::follow(const TissueModel& body) {
  if (body.totals().edits != edits_seen_) build_grid(body);
  const crms::Lattice& lattice = body.solver().lattice();
  const crms::LatticeGeometry& g = lattice.geometry();
  const std::vector<Vec3f> positions = body.solver().positions();
  const auto n = static_cast<std::size_t>(g.node_count());
  displacement_.resize(n);
  alive_.resize(n);
  max_displacement_ = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const auto node = static_cast<std::int64_t>(i);
    alive_[i] = lattice.alive(node) ? 1 : 0;
    displacement_[i] = alive_[i] ? positions[i] - to_float(g.rest_position(node)) : Vec3f{0, 0, 0};
    if (alive_[i])
      max_displacement_ = std::max(max_displacement_, double(length(displacement_[i])));
  }
  // Carry the motion kDilation node layers beyond the body (each empty node takes the mean of
  // its filled face neighbours): a point just outside the body is mapped with the body's motion,
  // not at rest, so a body that moves pushes what lies against it.
  std::vector<std::uint8_t> filled = alive_;
  std::vector<Vec3f> next = displacement_;
  for (int layer = 0; layer < kDilation; ++layer) {
    std::vector<std::uint8_t> grown = filled;
    for (int k = 0; k < g.dims.z; ++k)
      for (int j = 0; j < g.dims.y; ++j)
        for (int i = 0; i < g.dims.x; ++i) {
          const std::size_t at = static_cast<std::size_t>(g.index(i, j, k));
          if (filled[at]) continue;
          Vec3f sum{0, 0, 0};
          int count = 0;
          const int nb[6][3] = {{-1, 0, 0}, {1, 0, 0},  {0, -1, 0},
                                {0, 1, 0},  {0, 0, -1}, {0, 0, 1}};
          for (const auto& d : nb) {
            const int a = i + d[0], b = j + d[1], c = k + d[2];
            if (!g.contains(a, b, c)) continue;
            const std::size_t o = static_cast<std::size_t>(g.index(a, b, c));
            if (!filled[o]) continue;
            sum += displacement_[o];
            ++count;
          }
          if (count == 0) continue;
          next[at] = sum / static_cast<float>(count);
          grown[at] = 1;
        }
    filled.swap(grown);
    displacement_ = next;
  }
  alive_.swap(filled);
  view_.displacement = displacement_.data();
  view_.alive = alive_.data();
  view_.dims = g.dims;
  view_.origin = g.origin;
  view_.spacing = g.spacing;
}

namespace {

/// The density of `v` at tissue point p, trilinear (0 outside the volume).
double density_at(const VoxelVolume& v, const Vec3d& p) {
  const VolumeGeometry& g = v.geometry();
  const Vec3d c = g.tissue_to_index(p);
  int i0[3];
  double t[3];
  for (int a = 0; a < 3; ++a) {
    const double f = std::floor(c[a]);
    i0[a] = static_cast<int>(f);
    t[a] = c[a] - f;
  }
  double sum = 0;
  for (int corner = 0; corner < 8; ++corner) {
    const int i = i0[0] + (corner & 1), j = i0[1] + ((corner >> 1) & 1), k = i0[2] + (corner >> 2);
    if (i < 0 || j < 0 || k < 0 || i >= g.dims.x || j >= g.dims.y || k >= g.dims.z) continue;
    const double w = (corner & 1 ? t[0] : 1 - t[0]) * ((corner >> 1) & 1 ? t[1] : 1 - t[1]) *
                     (corner >> 2 ? t[2] : 1 - t[2]);
    sum += w * static_cast<double>(v.density(i, j, k));
  }
  return sum;
}

/// How far the tissue's own surface lies from rest point p along u (mm; negative: p is already
/// outside its tissue, the surface behind it), within ±reach; 0 when none is found.
double surface_along(const VoxelVolume& v, double iso, const Vec3d& p, const Vec3d& u, double reach,
                     double step) {
  const double f0 = density_at(v, p) - iso;
  const double dir = f0 >= 0 ? 1.0 : -1.0;  // inside: toward the body; outside: back into it
  double prev_t = 0, prev_f = f0;
  for (double t = step; t <= reach + 1e-9; t += step) {
    const double f = density_at(v, p + u * (dir * t)) - iso;
    if ((f0 >= 0) != (f >= 0)) {
      const double at = prev_t + (t - prev_t) * prev_f / (prev_f - f);
      return dir * at;
    }
    prev_t = t;
    prev_f = f;
  }
  return 0.0;
}

}  // namespace

void BodyField::set_rest_allowance(const TissueModel& pushed) {
  const crms::Lattice& lattice = pushed.solver().lattice();
  const crms::LatticeGeometry& g = lattice.geometry();
  const VoxelVolume& volume = pushed.volume();
  const Vec3d& vs = volume.geometry().spacing;
  const double step = 0.25 * std::min({vs.x, vs.y, vs.z});
  const double iso = pushed.options().surface.iso;
  allowance_.assign(static_cast<std::size_t>(g.node_count()), 0.0f);
  overlapping_ = 0;
  for (std::int64_t n = 0; n < g.node_count(); ++n) {
    if (!lattice.alive(n)) continue;
    const Vec3d p = g.rest_position(n);
    Vec3d normal;
    const double d = distance(p, normal);
    const double s = surface_along(volume, iso, p, normal * -1.0, g.min_spacing(), step);
    allowance_[static_cast<std::size_t>(n)] = static_cast<float>(std::min(s, d));
    overlapping_ += d < s ? 1 : 0;
  }
}

double BodyField::distance(const Vec3d& p, Vec3d& normal) const {
  const coupler::LocalWarp warp = coupler::inverse_warp(view_, p);
  Vec3d n_rest;
  const double d = grid_->distance(warp.rest_centre, n_rest);
  // A rest normal is a covector: it maps to the world by F⁻ᵀ.
  const double* Fi = warp.F_inv;
  const Vec3d n{Fi[0] * n_rest.x + Fi[3] * n_rest.y + Fi[6] * n_rest.z,
                Fi[1] * n_rest.x + Fi[4] * n_rest.y + Fi[7] * n_rest.z,
                Fi[2] * n_rest.x + Fi[5] * n_rest.y + Fi[8] * n_rest.z};
  const double len = length(n);
  normal = len > 1e-12 ? n / len : n_rest;
  return d;
}

void BodyField::bounds(Vec3d& lo, Vec3d& hi) const {
  const Vec3d m{max_displacement_, max_displacement_, max_displacement_};
  lo = grid_->lo() - m;
  hi = grid_->hi() + m;
}

}  // namespace tsf::interaction
